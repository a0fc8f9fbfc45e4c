"""The matches panel pages through one camera's pairs, most inliers first (issue 22)."""


def pairs_url(s, query: str) -> str:
    return f"/api/v1/projects/{s.pid}/versions/{s.vid}/pairs{query}"


def busiest_image(client, s) -> int:
    pairs = client.get(pairs_url(s, ""), headers=s.owner).json()
    counts: dict[int, int] = {}
    for p in pairs:
        for i in (p["image_id1"], p["image_id2"]):
            counts[i] = counts.get(i, 0) + 1
    return max(counts, key=counts.get)


def test_pages_of_one_image_add_up_to_its_pairs_most_inliers_first(client, reconstructed):
    s = reconstructed
    image = busiest_image(client, s)
    whole = client.get(pairs_url(s, f"?image_id={image}&order=inliers"), headers=s.owner)
    rows = whole.json()
    assert len(rows) >= 3 and whole.headers["x-total-count"] == str(len(rows))
    inliers = [r["num_inliers"] for r in rows]
    assert inliers == sorted(inliers, reverse=True)
    pages, offset = [], 0
    while True:
        page = client.get(pairs_url(s, f"?image_id={image}&order=inliers&limit=2&offset={offset}"),
                          headers=s.owner)
        assert page.headers["x-total-count"] == str(len(rows))  # the total, not the page's size
        if not page.json():
            break
        pages.append(page.json())
        offset += 2
    assert all(len(p) <= 2 for p in pages) and sum(pages, []) == rows


def test_the_default_order_and_the_whole_list_are_v1s(client, reconstructed):
    s = reconstructed
    rows = client.get(pairs_url(s, ""), headers=s.owner).json()
    assert client.get(pairs_url(s, "?order=pair"), headers=s.owner).json() == rows
    assert client.get(pairs_url(s, "?limit=3&offset=1"), headers=s.owner).json() == rows[1:4]


def test_an_unknown_order_is_422(client, reconstructed):
    assert client.get(pairs_url(reconstructed, "?order=name"),
                      headers=reconstructed.owner).status_code == 422


def test_paging_reads_the_version_once(client, reconstructed, store, monkeypatch):
    """The matches panel pages through a camera's pairs: on S3 every read of the version fetches
    its database, so the pairs of a version are read once and each page filtered from them."""
    s = reconstructed
    reads = []
    original = type(store).reading

    def counted(self, version, only=None):
        reads.append(version)
        return original(self, version, only)

    whole = client.get(pairs_url(s, ""), headers=s.owner).json()
    monkeypatch.setattr(type(store), "reading", counted)
    image = busiest_image(client, s)
    pages = [client.get(pairs_url(s, f"?image_id={image}&order=inliers&limit=2&offset={o}"),
                        headers=s.owner).json() for o in (0, 2, 4)]
    assert reads == []  # the first request above read it; none of these did
    mine = [p for p in whole if image in (p["image_id1"], p["image_id2"])]
    assert sum(pages, []) == sorted(mine, key=lambda p: -p["num_inliers"])[:6]
