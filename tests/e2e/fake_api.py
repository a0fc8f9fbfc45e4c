"""A small in-memory stand-in for the REST contract, answered through Playwright's request routing,
for browser tests of editor details the rendered sample cannot show (an unregistered image, a split
match graph, an older version). It serves frontend/ from disk too, so no server runs."""

from __future__ import annotations

import base64
import json
import math
import re
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

FRONTEND = Path(__file__).resolve().parents[2] / "frontend"
ORIGIN = "http://gsfm.test"
PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNkaPhfDwAEhQGAhKmM"
                       "IQAAAABJRU5ErkJggg==")  # one grey pixel
TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css"}
CUT_DISTANCE = 2.5  # the fake rule: a moved camera loses the pairs to cameras farther than this


def camera(image_id: int, x: float | None, registered: bool = True, y: float = 0.0) -> dict:
    """A scene camera looking along +y; the ground frame is the world's x-y plane."""
    placed = registered and x is not None
    return {"image_id": image_id, "name": f"{image_id:04d}.jpg", "seq": image_id - 1,
            "registered": registered, "model": 0 if placed else None,
            "x": x if placed else None, "y": y if placed else None, "yaw_deg": 90.0 if placed else None,
            "fov_deg": 60.0, "range": 2.0 if placed else None,
            "center": [x, y, 0.0] if placed else None, "qvec": [1.0, 0.0, 0.0, 0.0] if placed else None}


EDIT_FIELDS = {"base_version_id", "cameras", "delete_pairs", "flags", "rule", "tolerances"}
CAMERA_FIELDS = {"image_id", "x", "y", "yaw_deg", "fov_deg", "range"}


def extra_fields(request) -> list[str]:
    """The fields of an edit-set body the real API refuses (its request models forbid extras)."""
    body = request.post_data_json
    if not isinstance(body, dict):
        return []
    extra = sorted(set(body) - EDIT_FIELDS)
    cameras = body.get("cameras") if isinstance(body.get("cameras"), list) else []
    return extra + [f"cameras.{i}.{k}" for i, c in enumerate(cameras) for k in sorted(set(c) - CAMERA_FIELDS)]


class FakeApi:
    """Project 1 with five cameras in a row (ids 1-5), one unregistered image (6), seven pairs.

    `older` gives earlier versions' cameras (version id -> cameras; default: the head's);
    `compare` overrides the answer of GET .../versions/{vid}/compare (default: the distances
    between the two versions' camera centres, as if the server had aligned them); `stray` adds
    far points to the scene's; `role` is the caller's; `refuse_edits` answers 403 to saving an
    edit set, as the server does once the caller's role became viewer; `jobs` are the project's."""

    def __init__(self, head: int = 1, older: dict[int, list[dict]] | None = None,
                 compare: list[dict] | None = None, stray: list[list[float]] = (),
                 role: str = "owner", refuse_edits: bool = False, jobs: list[dict] = ()) -> None:
        self.cameras = [camera(i, float(i - 1)) for i in range(1, 6)] + [camera(6, None, False)]
        self.pairs = {(1, 2): 100, (2, 3): 80, (3, 4): 120, (4, 5): 60, (1, 3): 30, (2, 4): 40, (3, 5): 50}
        self.head = head
        self.older = older or {}
        self.compare_answer = compare
        self.role, self.refuse_edits, self.jobs = role, refuse_edits, list(jobs)
        self.deleted = False
        self.uploads: list[list[str]] = []  # file names per upload request
        self.stored_names: set[str] = set()
        self.decimate = False  # send every other point unless ?max_points= asks (a big scene)
        self.lose_next_upload = False  # store the next upload, then answer 502 (a lost answer)
        self.points = [[x / 4, 2.0 + (x % 3) / 10] for x in range(-4, 24)] + [list(p) for p in stray]
        self.edit: dict | None = None
        self.suspects: dict = {"suspects": [], "runs": []}
        self.log: list[tuple[str, str]] = []

    def install(self, page) -> None:
        page.route(f"{ORIGIN}/**", self.handle)

    def handle(self, route, request) -> None:
        path = urlsplit(request.url).path
        if not path.startswith("/api/v1/"):
            file = FRONTEND / (path.lstrip("/") or "index.html")
            route.fulfill(status=200, body=file.read_bytes(),
                          content_type=TYPES.get(file.suffix, "text/plain"))
            return
        self.log.append((request.method, path))
        status, body = self.answer(request.method, path.removeprefix("/api/v1"), request)
        if status == 204:
            route.fulfill(status=204)
        elif isinstance(body, bytes):
            route.fulfill(status=status, body=body, content_type="image/png")
        else:
            revision = body.get("revision") if isinstance(body, dict) else None
            headers = {"ETag": f'"{revision}"'} if revision is not None else {}
            route.fulfill(status=status, body=json.dumps(body), content_type="application/json",
                          headers=headers)

    def answer(self, method: str, path: str, request) -> tuple[int, object]:
        project = {"id": 1, "name": "fake", "description": "", "head_version_id": self.head,
                   "created_at": "2026-01-01T00:00:00Z", "role": self.role, "owner": "fake-owner"}
        routes = {
            ("POST", "/auth/token"): lambda: {"access_token": "fake", "token_type": "bearer"},
            ("GET", "/projects"): lambda: [] if self.deleted else [project],
            ("GET", "/projects/1"): lambda: project,
            ("GET", "/projects/1/versions"): self.versions,
            ("GET", "/projects/1/members"): lambda: [{"username": "fake-user", "role": "owner"}],
            ("GET", "/projects/1/jobs"): lambda: self.jobs,
            ("GET", "/projects/1/edits"): lambda: [self.edit] if self.edit else [],
            ("GET", "/projects/1/edits/1"): lambda: self.edit,
            ("GET", "/projects/1/edits/1/preview"): self.preview,
            # team review (v1.1): nobody else here, nothing said yet
            ("GET", "/projects/1/comments"): lambda: [],
            ("POST", "/projects/1/presence"): lambda: [{"username": "fake-user", "edit_set_id": None,
                                                        "version_id": self.head,
                                                        "seen_at": "2026-01-01T00:00:00Z"}],
            ("GET", "/projects/1/activity"): lambda: {"items": [], "next_before": None},
            ("GET", "/notifications"): lambda: [],
        }
        if (method, path) in routes:
            return 200, routes[(method, path)]()
        team = {("GET", "/projects/1/comments"): [], ("POST", "/projects/1/presence"): [],
                ("GET", "/notifications"): [], ("POST", "/notifications/read"): [],
                ("GET", "/projects/1/activity"): {"items": [], "next_before": None}}
        if (method, path) in team:  # the team panels (v1.1): nobody else is here
            return 200, team[(method, path)]
        if path.endswith("/scene"):
            frame = {"origin": [0, 0, 0], "x_axis": [1, 0, 0], "y_axis": [0, 1, 0], "up": [0, 0, 1]}
            query = parse_qs(urlsplit(request.url).query)
            xy = self.points if "max_points" in query or not self.decimate else self.points[::2]
            return 200, {"frame": frame, "cameras": self.cameras_of(version_of(path)),
                         "models": [{"index": 0, "num_images": 5}],
                         "points": {"xy": xy, "total": len(self.points)}}
        if path.endswith("/suspects"):  # triage (v1.1): set `suspects` to raise some
            return 200, self.suspects
        if path.endswith("/compare"):
            to = int(parse_qs(urlsplit(request.url).query)["to"][0])
            return 200, {"cameras": self.compare_answer or self.compare(version_of(path), to)}
        if path.endswith("/pairs"):
            return 200, [{"image_id1": a, "image_id2": b, "num_inliers": n}
                         for (a, b), n in self.pairs.items()]
        if path.endswith("/thumbnail"):
            return 200, PNG
        if path.startswith("/projects/1/edits") and method in ("POST", "PUT") and self.refuse_edits:
            return 403, {"detail": "your role in project 1 is viewer; this needs editor"}
        if path.startswith("/projects/1/edits") and method in ("POST", "PUT") and extra_fields(request):
            return 422, {"detail": f"{extra_fields(request)[0]}: Extra inputs are not permitted"}
        if path.startswith("/projects/1/images/") and method == "DELETE":
            image_id = int(path.rsplit("/", 1)[1])
            if any(c["image_id"] == image_id and c["center"] for c in self.cameras):
                return 409, {"detail": f"image {image_id:04d}.jpg is used by version(s) v{self.head}"}
            self.cameras = [c for c in self.cameras if c["image_id"] != image_id]
            return 204, {}
        if path == "/projects/1" and method == "DELETE":
            self.deleted = True
            return 204, {}
        if path.endswith("/export"):
            return 200, b"PK fake export"
        if path == "/projects/1/images" and method == "POST":
            return self.upload(request)
        if path == "/projects/1/reconstruct" and method == "POST":
            return 409, {"detail": "a job of project 1 is queued or running"}
        if path == "/projects/1/edits" and method == "POST":
            self.edit = {**request.post_data_json, "id": 1, "revision": 1, "updated_by": "fake-user",
                         "updated_at": "2026-01-01T00:00:00Z"}
            return 201, self.edit
        if path == "/projects/1/edits/1/rebase" and method == "POST":
            return self.rebase(request)
        if path == "/projects/1/edits/1" and method == "PUT":
            if request.headers.get("if-match", "").strip('"') != str(self.edit["revision"]):
                return 409, {"detail": "edit set 1 was saved by someone else"}
            self.edit = {**self.edit, **request.post_data_json, "revision": self.edit["revision"] + 1}
            return 200, self.edit
        return 404, {"detail": f"the fake API has no {method} {path}"}

    def upload(self, request) -> tuple[int, object]:
        """All or nothing, as the server: a file whose name starts with "bad" fails the request."""
        names = re.findall(r'filename="([^"]+)"', request.post_data_buffer.decode("latin-1"))
        self.uploads.append(names)
        bad = [n for n in names if n.startswith("bad")]
        if bad:
            return 422, {"detail": f"{bad[0]}: not a readable JPEG or PNG image (cannot identify image file)"}
        answer = [{"id": 100 + i, "name": n, "width": 8, "height": 8, "seq": i,
                   "already_uploaded": n in self.stored_names} for i, n in enumerate(names)]
        self.stored_names |= set(names)  # idempotent by name here (the server also compares bytes)
        if self.lose_next_upload:
            self.lose_next_upload = False
            return 502, {"detail": "bad gateway"}
        return 201, answer

    def rebase(self, request) -> tuple[int, dict]:
        """Carry the edit set onto the head: cameras on the head's images, deletions of its pairs."""
        if request.headers.get("if-match", "").strip('"') != str(self.edit["revision"]):
            return 409, {"detail": "edit set 1 was saved by someone else"}
        images = {c["image_id"] for c in self.cameras_of(self.head)}
        old, cameras = self.edit, [c for c in self.edit["cameras"] if c["image_id"] in images]
        pairs = [p for p in old["delete_pairs"] if tuple(sorted(p)) in self.pairs]
        dropped = [{"kind": "camera", "image_ids": [c["image_id"]], "reason": f"not part of v{self.head}"}
                   for c in old["cameras"] if c not in cameras]
        dropped += [{"kind": "delete_pair", "image_ids": p, "reason": f"v{self.head} does not match it"}
                    for p in old["delete_pairs"] if p not in pairs]
        self.edit = {**old, "base_version_id": self.head, "cameras": cameras, "delete_pairs": pairs,
                     "revision": old["revision"] + 1}
        carried = {"cameras": [c["image_id"] for c in cameras], "delete_pairs": pairs, "flags": old["flags"]}
        return 200, {**self.edit, "report": {"from_version": old["base_version_id"], "to_version": self.head,
                                             "carried": carried, "dropped": dropped}}

    def versions(self) -> list[dict]:
        stats = {"num_images": 6, "num_registered": 5, "num_models": 1, "num_pairs": 7, "num_points": 28}
        return [{"id": v, "parent_id": v - 1 or None, "kind": "reconstruct" if v == 1 else "apply",
                 "author": "fake-user", "message": "", "created_at": "2026-01-01T00:00:00Z", "stats": stats}
                for v in range(self.head, 0, -1)]

    def cameras_of(self, version: int) -> list[dict]:
        return self.older.get(version, self.cameras)

    def compare(self, version: int, to: int) -> list[dict]:
        """Per registered camera of `to`: how far its centre is from the one in `version`."""
        before = {c["image_id"]: c for c in self.cameras_of(version) if c["center"]}
        return [{"image_id": c["image_id"], "moved": math.dist(c["center"], before[c["image_id"]]["center"]),
                 "rotated_deg": abs(c["yaw_deg"] - before[c["image_id"]]["yaw_deg"])}
                for c in self.cameras_of(to) if c["center"] and c["image_id"] in before]

    def preview(self) -> dict:
        """Manual deletions, plus pairs of a moved camera now farther apart than CUT_DISTANCE."""
        placed = {c["image_id"]: (c["x"], c["y"]) for c in self.cameras if c["x"] is not None}
        placed.update({c["image_id"]: (c["x"], c["y"]) for c in self.edit["cameras"]})
        moved = {c["image_id"] for c in self.edit["cameras"]}
        reasons = {tuple(sorted(p)): ["manual"] for p in self.edit["delete_pairs"]}
        for a, b in self.pairs:
            if (a in moved or b in moved) and math.dist(placed[a], placed[b]) > CUT_DISTANCE:
                reasons.setdefault((a, b), ["placement", "relative_pose"])  # as the default rule's
        cut = sorted(reasons)
        kept = [p for p in self.pairs if p not in reasons]
        by_test = {t: sum(t in r for r in reasons.values()) for t in ("placement", "relative_pose", "manual")}
        return {"pairs_to_delete": [list(p) for p in cut],
                "components_before": components(self.pairs),
                "components_after": components(kept, {i for p in self.pairs for i in p}),
                "removed_by_test": by_test, "kept_to_connect": [],
                "reasons": [{"pair": list(p), "tests": reasons[p]} for p in cut]}


def version_of(path: str) -> int:
    """The version id of .../versions/{vid}/..."""
    return int(path.split("/versions/")[1].split("/")[0])


def components(pairs, images: set[int] | None = None) -> int:
    """Connected components of the images (default: those in `pairs`) under the pairs."""
    parent = {i: i for i in images or {i for p in pairs for i in p}}

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for a, b in pairs:
        parent[root(a)] = root(b)
    return len({root(i) for i in parent})
