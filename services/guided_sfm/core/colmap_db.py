"""The COLMAP matching database: verified pairs, their matches, and pruned copies for new versions."""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterable
from contextlib import closing, contextmanager
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core.errors import InvalidInput, MissingWorkspace
from guided_sfm.core.geometry import horizontal_fov_deg
from guided_sfm.core.pose_prior import PositionPrior
from guided_sfm.core.types import PairKey, pair_key

# Mapping reads keypoints, matches and two-view geometries, never descriptors, so a pruned
# version's database leaves them out: it costs kilobytes per image instead of megabytes.
SKIPPED_TABLES = ("descriptors",)
SQL_CHUNK = 500  # pair ids per IN (...) query, below SQLite's bound-parameter limit
COLMAP_TABLES = ("cameras", "images", "keypoints", "matches", "two_view_geometries")
CHECK_SECONDS = 60.0  # an outside database's checks stop after this (a huge file is refused)


@contextmanager
def read_only(path: Path):
    """A read-only sqlite connection to an existing database: reading never changes a version."""
    if not Path(path).is_file():
        raise MissingWorkspace(f"no COLMAP database at {path}")
    conn = sqlite3.connect(f"file:{Path(path).resolve()}?mode=ro", uri=True)
    try:
        yield conn
    finally:
        conn.close()


def check_untrusted(path: Path, seconds: float = CHECK_SECONDS) -> None:
    """Refuse a COLMAP database from outside before anything else reads it: only plain tables (a
    view or trigger runs whatever query it holds, an endless recursive one included), COLMAP's
    tables present, integrity intact. Opened read-only with an untrusted schema, bounded in time."""
    conn = sqlite3.connect(f"file:{Path(path).resolve()}?mode=ro", uri=True)
    deadline = time.monotonic() + seconds
    conn.set_progress_handler(lambda: int(time.monotonic() > deadline), 10_000)
    try:
        with closing(conn):
            conn.execute("PRAGMA trusted_schema=OFF")
            schema = conn.execute("SELECT type, name, sql FROM sqlite_master").fetchall()
            _check_schema(schema)
            problems = [row[0] for row in conn.execute("PRAGMA integrity_check(5)")]
    except sqlite3.DatabaseError as exc:  # includes "interrupted" once past the deadline
        raise InvalidInput(f"database.db is not a usable SQLite database ({exc})") from exc
    if problems != ["ok"]:
        raise InvalidInput(f"database.db fails SQLite's integrity check: {'; '.join(problems)}")


def _check_schema(schema: list[tuple[str, str, str | None]]) -> None:
    odd = [f"{kind} {name}" for kind, name, sql in schema
           if kind not in ("table", "index") or (sql or "").upper().startswith("CREATE VIRTUAL")]
    if odd:
        raise InvalidInput(f"database.db may hold only tables and indexes; it has {', '.join(odd[:5])}")
    missing = sorted(set(COLMAP_TABLES) - {name for kind, name, _ in schema if kind == "table"})
    if missing:
        raise InvalidInput(f"database.db is not a COLMAP database: no table {', '.join(missing)}")


def _blob(data: bytes, rows: int, cols: int, dtype) -> np.ndarray:
    return np.frombuffer(data or b"", dtype=dtype).reshape(rows, cols)


def image_names(path: Path) -> dict[int, str]:
    """COLMAP image id -> file name of every image in the database."""
    with read_only(path) as conn:
        return dict(conn.execute("SELECT image_id, name FROM images"))


def verified_pairs(path: Path) -> dict[PairKey, int]:
    """Every verified image pair with at least one inlier match -> its number of inliers."""
    with read_only(path) as conn:
        rows = conn.execute("SELECT pair_id, rows FROM two_view_geometries WHERE rows > 0")
        return {pair_key(*pycolmap.pair_id_to_image_pair(pid)): int(n) for pid, n in rows}


def matched_pair_count(path: Path) -> int:
    """How many image pairs were matched (verified or not): the matcher's candidate pairs."""
    with read_only(path) as conn:
        return conn.execute("SELECT COUNT(*) FROM matches").fetchone()[0]


def inlier_matches(path: Path, pair: PairKey) -> np.ndarray:
    """(N, 2) keypoint indices of a pair's verified inlier matches, columns in pair order."""
    pair_id = pycolmap.image_pair_to_pair_id(*pair)
    with read_only(path) as conn:
        row = conn.execute("SELECT rows, cols, data FROM two_view_geometries WHERE pair_id = ?",
                           (pair_id,)).fetchone()
    if row is None or not row[0]:
        return np.zeros((0, 2), dtype=np.int64)
    return _blob(row[2], row[0], row[1], np.uint32).astype(np.int64)


def all_inlier_matches(path: Path) -> dict[PairKey, np.ndarray]:
    """Every verified pair's inlier matches, columns ordered as the pair key, in one read."""
    # COLMAP stores a pair under its smaller image id first, which is the pair key's order.
    with read_only(path) as conn:
        rows = conn.execute(
            "SELECT pair_id, rows, cols, data FROM two_view_geometries WHERE rows > 0")
        return {pair_key(*pycolmap.pair_id_to_image_pair(pid)):
                _blob(data, n, cols, np.uint32).astype(np.int64) for pid, n, cols, data in rows}


def inlier_matches_of(path: Path, pairs: Iterable[PairKey]) -> dict[PairKey, np.ndarray]:
    """The listed pairs' inlier matches (columns in pair-key order); pairs without any are left out."""
    wanted = sorted({pycolmap.image_pair_to_pair_id(*pair_key(*pair)) for pair in pairs})
    found = {}
    with read_only(path) as conn:
        for start in range(0, len(wanted), SQL_CHUNK):
            chunk = wanted[start:start + SQL_CHUNK]
            rows = conn.execute("SELECT pair_id, rows, cols, data FROM two_view_geometries "
                                f"WHERE rows > 0 AND pair_id IN ({','.join('?' * len(chunk))})",
                                chunk)
            found.update({pair_key(*pycolmap.pair_id_to_image_pair(pid)):
                          _blob(data, n, cols, np.uint32).astype(np.int64)
                          for pid, n, cols, data in rows})
    return found


def keypoint_counts(path: Path, image_ids: Iterable[int] | None = None) -> dict[int, int]:
    """COLMAP image id -> how many keypoints the database lists for it, for these images (those
    it has any for) or, without image_ids, for every image."""
    if image_ids is None:
        with read_only(path) as conn:
            return dict(conn.execute("SELECT image_id, rows FROM keypoints"))
    wanted, found = sorted(set(image_ids)), {}
    with read_only(path) as conn:
        for start in range(0, len(wanted), SQL_CHUNK):
            chunk = wanted[start:start + SQL_CHUNK]
            found.update(conn.execute("SELECT image_id, rows FROM keypoints "
                                      f"WHERE image_id IN ({','.join('?' * len(chunk))})", chunk))
    return found


def keypoints(path: Path, image_id: int) -> np.ndarray:
    """(N, 2) keypoint positions of an image in pixels (COLMAP origin: pixel corner)."""
    with read_only(path) as conn:
        row = conn.execute("SELECT rows, cols, data FROM keypoints WHERE image_id = ?",
                           (image_id,)).fetchone()
    if row is None or not row[0]:
        return np.zeros((0, 2))
    return _blob(row[2], row[0], row[1], np.float32)[:, :2].astype(float)


def copy_without_pairs(source: Path, target: Path, deleted: Iterable[PairKey]) -> int:
    """Write a new database at target: source minus the deleted pairs (and descriptors).

    The source is opened read-only and left untouched. Returns how many pairs it deleted.
    """
    if not Path(source).is_file():
        raise MissingWorkspace(f"no COLMAP database at {source}")
    target = Path(target)
    target.unlink(missing_ok=True)
    pair_ids = [(pycolmap.image_pair_to_pair_id(*pair),) for pair in deleted]
    with closing(sqlite3.connect(f"file:{target}", uri=True)) as conn:
        conn.execute("ATTACH DATABASE ? AS src", (f"file:{source}?mode=ro",))
        _copy_tables(conn)
        conn.execute("CREATE TEMP TABLE deleted (pair_id INTEGER PRIMARY KEY)")
        conn.executemany("INSERT OR IGNORE INTO deleted VALUES (?)", pair_ids)
        count = conn.execute(
            "DELETE FROM main.two_view_geometries WHERE pair_id IN (SELECT pair_id FROM deleted)"
        ).rowcount
        conn.execute("DELETE FROM main.matches WHERE pair_id IN (SELECT pair_id FROM deleted)")
        conn.commit()
        conn.execute("DETACH DATABASE src")
    return count


def _copy_tables(conn: sqlite3.Connection) -> None:
    """Recreate the source schema in main and copy every table's rows but the skipped ones."""
    schema = conn.execute(
        "SELECT type, name, sql FROM src.sqlite_master WHERE sql IS NOT NULL "
        "AND name NOT LIKE 'sqlite_%' ORDER BY type = 'table' DESC"
    ).fetchall()
    for kind, name, sql in schema:
        conn.execute(sql)
        if kind == "table" and name not in SKIPPED_TABLES:
            conn.execute(f'INSERT INTO main."{name}" SELECT * FROM src."{name}"')
    conn.commit()


def write_position_priors(path: Path, priors: Iterable[PositionPrior]) -> int:
    """Replace the database's pose priors with these positions (Cartesian, in the model's frame,
    no gravity); returns how many were written."""
    with read_only(path) as conn:
        camera_of = dict(conn.execute("SELECT image_id, camera_id FROM images"))
    count = 0
    with pycolmap.Database.open(path) as database:
        database.clear_pose_priors()
        for prior in priors:
            sensor = pycolmap.sensor_t(type=pycolmap.SensorType.CAMERA, id=camera_of[prior.image_id])
            database.write_pose_prior(pycolmap.PosePrior(
                corr_data_id=pycolmap.data_t(sensor_id=sensor, id=prior.image_id),
                position=np.asarray(prior.position, dtype=float),
                position_covariance=np.asarray(prior.covariance, dtype=float),
                coordinate_system=pycolmap.PosePriorCoordinateSystem.CARTESIAN))
            count += 1
    finalize(path)
    return count


def count_pose_priors(path: Path) -> int:
    """How many pose priors the database holds (0 for a database without their table)."""
    with read_only(path) as conn:
        if not conn.execute("SELECT 1 FROM sqlite_master WHERE name = 'pose_priors'").fetchone():
            return 0
        return int(conn.execute("SELECT COUNT(*) FROM pose_priors").fetchone()[0])


def read_position_priors(path: Path) -> list[PositionPrior]:
    """The database's pose priors with a position, sorted by image id."""
    with pycolmap.Database.open(path) as database:
        priors = [PositionPrior(int(p.corr_data_id.id), np.array(p.position),
                                np.array(p.position_covariance))
                  for p in database.read_all_pose_priors() if p.has_position()]
    return sorted(priors, key=lambda prior: prior.image_id)


def fov_by_image(path: Path) -> dict[int, float]:
    """Horizontal field of view (deg) of every image from its camera's focal length."""
    # Every COLMAP camera model stores its (x) focal length first.
    with read_only(path) as conn:
        cameras = {cid: (width, np.frombuffer(params, dtype=np.float64)[0])
                   for cid, width, params in conn.execute(
                       "SELECT camera_id, width, params FROM cameras")}
        images = conn.execute("SELECT image_id, camera_id FROM images").fetchall()
    return {iid: horizontal_fov_deg(cameras[cid][1], cameras[cid][0]) for iid, cid in images}


def finalize(path: Path) -> None:
    """Fold COLMAP's write-ahead log into the file, so the database is one self-contained file."""
    with closing(sqlite3.connect(path)) as conn:
        conn.execute("PRAGMA journal_mode=DELETE")


CAMERA = int(pycolmap.SensorType.CAMERA)


def share_cameras(path: Path) -> int:
    """Join cameras of identical model, size and starting parameters into one; returns how many went.

    Extraction gives every image its own camera so that verification uses COLMAP's uncalibrated
    solvers (far cheaper than the shared-focal one a shared camera without a focal prior gets);
    the mapper then refines one camera per kind of image, as the capture really had. Every row
    naming a joined camera follows it (images, frames, rigs, pose priors); cameras of real
    multi-sensor rigs are left alone.
    """
    with closing(sqlite3.connect(path)) as conn:
        joined = _cameras_to_join(conn)
        if not joined:
            return 0
        rig_of = dict(conn.execute("SELECT ref_sensor_id, rig_id FROM rigs WHERE ref_sensor_type = ?",
                                   (CAMERA,)))
        for gone, keep in joined.items():
            _join_camera(conn, gone, keep, rig_of)
        _forget_joined_cameras_of_pairs(conn, set(joined))
        conn.commit()
    return len(joined)


def _cameras_to_join(conn: sqlite3.Connection) -> dict[int, int]:
    """Camera id -> the first camera of the same kind (model, size, parameters, prior), for
    cameras outside multi-sensor rigs."""
    rows = conn.execute("SELECT camera_id, model, width, height, params, prior_focal_length "
                        "FROM cameras ORDER BY camera_id").fetchall()
    in_rigs = {sensor for (sensor,) in conn.execute(
        "SELECT sensor_id FROM rig_sensors WHERE sensor_type = ? UNION "
        "SELECT ref_sensor_id FROM rigs r WHERE ref_sensor_type = ? AND EXISTS "
        "(SELECT 1 FROM rig_sensors s WHERE s.rig_id = r.rig_id)", (CAMERA, CAMERA))}
    kinds: dict[tuple, int] = {}
    joined: dict[int, int] = {}
    for camera_id, *kind in rows:
        if camera_id not in in_rigs:
            keep = kinds.setdefault(tuple(kind), camera_id)
            if keep != camera_id:
                joined[camera_id] = keep
    return joined


def _join_camera(conn: sqlite3.Connection, gone: int, keep: int, rig_of: dict[int, int]) -> None:
    """Every row naming camera `gone` names `keep` instead; rig_of (camera -> its rig) follows."""
    conn.execute("UPDATE images SET camera_id = ? WHERE camera_id = ?", (keep, gone))
    conn.execute("UPDATE frame_data SET sensor_id = ? WHERE sensor_id = ? AND sensor_type = ?",
                 (keep, gone, CAMERA))
    conn.execute("UPDATE pose_priors SET corr_sensor_id = ? "
                 "WHERE corr_sensor_id = ? AND corr_sensor_type = ?", (keep, gone, CAMERA))
    if gone in rig_of and keep in rig_of:
        conn.execute("UPDATE frames SET rig_id = ? WHERE rig_id = ?", (rig_of[keep], rig_of[gone]))
        conn.execute("DELETE FROM rigs WHERE rig_id = ?", (rig_of[gone],))
    elif gone in rig_of:  # the kept camera had no rig yet: this one becomes its rig
        conn.execute("UPDATE rigs SET ref_sensor_id = ? WHERE rig_id = ?", (keep, rig_of[gone]))
        rig_of[keep] = rig_of.pop(gone)
    conn.execute("DELETE FROM cameras WHERE camera_id = ?", (gone,))


def _forget_joined_cameras_of_pairs(conn: sqlite3.Connection, joined: set[int]) -> None:
    """Drop the cameras a pair's geometry was estimated with when one of them was joined away.

    COLMAP stores them (id first, 4 bytes little-endian) only for some pairs, e.g. one image
    with a focal prior and one without; mapping re-estimates its first pair and never reads them.
    """
    for pair_id, *cameras in conn.execute(
            "SELECT pair_id, camera1, camera2 FROM two_view_geometries "
            "WHERE camera1 IS NOT NULL OR camera2 IS NOT NULL").fetchall():
        if any(blob and int.from_bytes(blob[:4], "little") in joined for blob in cameras):
            conn.execute("UPDATE two_view_geometries SET camera1 = NULL, camera2 = NULL "
                         "WHERE pair_id = ?", (pair_id,))
