"""Pair deletion on a real pycolmap database: a new database, the parent untouched."""

import hashlib
import sqlite3

import pytest

from guided_sfm.core import colmap_db, workspace


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_verified_pairs_have_inliers(tiny_workspace_ro):
    pairs = colmap_db.verified_pairs(tiny_workspace_ro / workspace.DATABASE)
    assert len(pairs) >= 10
    assert all(a < b and count > 0 for (a, b), count in pairs.items())


def test_copy_without_pairs_leaves_parent_and_drops_only_those(tiny_workspace, tmp_path):
    source = tiny_workspace / workspace.DATABASE
    before = _digest(source)
    pairs = colmap_db.verified_pairs(source)
    removed = sorted(pairs)[:3]
    target = tmp_path / "pruned.db"
    assert colmap_db.copy_without_pairs(source, target, removed) == 3
    assert _digest(source) == before
    kept = colmap_db.verified_pairs(target)
    assert set(kept) == set(pairs) - set(removed)
    assert all(kept[p] == pairs[p] for p in kept)
    with sqlite3.connect(target) as conn:
        assert conn.execute("SELECT COUNT(*) FROM descriptors").fetchone()[0] == 0
        assert conn.execute("SELECT COUNT(*) FROM keypoints").fetchone()[0] > 0
        pair_ids = {r[0] for r in conn.execute("SELECT pair_id FROM matches")}
    import pycolmap

    assert not {pycolmap.image_pair_to_pair_id(*p) for p in removed} & pair_ids
    assert target.stat().st_size < source.stat().st_size


def test_inlier_matches_are_ordered_as_the_pair_key(tiny_workspace_ro):
    database = tiny_workspace_ro / workspace.DATABASE
    table = colmap_db.all_inlier_matches(database)
    pair = next(iter(table))
    single = colmap_db.inlier_matches(database, pair)
    assert sorted(map(tuple, single)) == sorted(map(tuple, table[pair]))
    kp1, kp2 = (colmap_db.keypoints(database, i) for i in pair)
    assert table[pair][:, 0].max() < len(kp1) and table[pair][:, 1].max() < len(kp2)


def _plain_colmap_tables(path):
    conn = sqlite3.connect(path)
    for table in colmap_db.COLMAP_TABLES:
        conn.execute(f"CREATE TABLE {table} (id INTEGER PRIMARY KEY)")
    return conn


@pytest.mark.parametrize("extra, named", [
    ("CREATE TRIGGER t AFTER INSERT ON cameras BEGIN DELETE FROM images; END", "trigger t"),
    ("CREATE VIEW v AS SELECT 1", "view v"),
    ("DROP TABLE matches", "no table matches"),
])
def test_an_outside_database_holds_only_colmap_tables(tmp_path, extra, named):
    from guided_sfm.core.errors import InvalidInput

    conn = _plain_colmap_tables(tmp_path / "db.db")
    conn.execute(extra)
    conn.commit()
    conn.close()
    with pytest.raises(InvalidInput, match=named):
        colmap_db.check_untrusted(tmp_path / "db.db")
    (tmp_path / "junk.db").write_bytes(b"not sqlite at all" * 100)
    with pytest.raises(InvalidInput, match="not a usable SQLite database"):
        colmap_db.check_untrusted(tmp_path / "junk.db")


def test_a_plain_colmap_database_passes(tmp_path):
    _plain_colmap_tables(tmp_path / "db.db").close()
    colmap_db.check_untrusted(tmp_path / "db.db")
