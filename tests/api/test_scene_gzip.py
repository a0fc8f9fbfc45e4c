"""The scene is sent gzipped to clients that accept it (design.md v1.1, Scale)."""

import pytest


@pytest.mark.parametrize(("accept", "gzipped"), [
    ("gzip, deflate", True), ("br;q=1.0, GZIP;q=0.5", True), ("*", True),
    ("identity", False), ("gzip;q=0", False), ("deflate", False),
])
def test_scene_is_gzipped_when_the_client_accepts_it(client, reconstructed, accept, gzipped):
    s = reconstructed
    url = f"/api/v1/projects/{s.pid}/versions/{s.vid}/scene"
    plain = client.get(url, headers={**s.owner, "Accept-Encoding": "identity"})
    response = client.get(url, headers={**s.owner, "Accept-Encoding": accept})
    assert response.status_code == 200 and "Accept-Encoding" in response.headers["vary"]
    assert (response.headers.get("content-encoding") == "gzip") is gzipped
    assert response.json() == plain.json()  # the client decodes it to the same scene
    if gzipped:  # bytes on the wire: a fraction of the JSON
        assert response.num_bytes_downloaded < 0.5 * plain.num_bytes_downloaded
