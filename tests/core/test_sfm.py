"""Extraction and matching choices of the engine: feature budgets, call blocks, shared cameras."""

import shutil
import sqlite3
from contextlib import closing
from dataclasses import replace

import pycolmap
import pytest
from PIL import Image

from guided_sfm.core import colmap_db, sfm
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.workspace import Workspace

from .conftest import TINY_OPTIONS


@pytest.mark.parametrize(("size", "budget"), [
    ((640, 480), 1024),     # the rendered samples
    ((1024, 768), 2621),    # the real Lund photographs
    ((4032, 3024), 8192),   # a phone photo: COLMAP's own default is the ceiling
    ((64, 64), 1024),       # never fewer than the floor
])
def test_feature_budget_follows_the_image_area(size, budget):
    assert sfm.features_for_size(*size) == budget


def test_an_explicit_feature_count_is_checked():
    with pytest.raises(InvalidInput, match="max_num_features"):
        SfmOptions(max_num_features=10)


def test_a_max_image_size_extracts_from_a_smaller_image_in_the_files_pixels(tiny_sample, tmp_path):
    images = tmp_path / "images"
    images.mkdir()
    for name in sorted(p.name for p in (tiny_sample / "images").iterdir())[:2]:
        shutil.copy(tiny_sample / "images" / name, images / name)
    with Image.open(next(images.iterdir())) as img:
        width, height = img.size
    full, small = tmp_path / "full.db", tmp_path / "small.db"
    sfm.extract_features(images, full, RunContext(TINY_OPTIONS))
    sfm.extract_features(images, small, RunContext(replace(TINY_OPTIONS, max_image_size=width // 2)))
    assert sum(colmap_db.keypoint_counts(small).values()) < sum(colmap_db.keypoint_counts(full).values())
    for image_id in colmap_db.image_names(small):  # scaled back to the file's pixels
        xy = colmap_db.keypoints(small, image_id)
        assert xy[:, 0].max() > 0.75 * width and xy[:, 1].max() > 0.75 * height
    with pytest.raises(InvalidInput, match="max_image_size"):
        SfmOptions(max_image_size=10)
    # the default leaves images at or below its size as they are: COLMAP's own features
    assert max(width, height) <= sfm.DEFAULT_MAX_IMAGE_SIZE < 3200
    default, colmaps = tmp_path / "default.db", tmp_path / "colmap.db"
    sfm.extract_features(images, default, RunContext(TINY_OPTIONS))  # the default max size
    sfm.extract_features(images, colmaps, RunContext(replace(TINY_OPTIONS, max_image_size=None)))
    by_name = [{name: colmap_db.keypoints(db, image_id).tolist()
                for image_id, name in colmap_db.image_names(db).items()} for db in (default, colmaps)]
    assert by_name[0] == by_name[1]


def test_extraction_and_matching_report_their_start(tiny_sample, tmp_path):
    """A stage's clock starts at its first report: one only after the first chunk or block would
    leave that chunk out of extraction and put that block into it."""
    images = tmp_path / "images"
    images.mkdir()
    for name in sorted(p.name for p in (tiny_sample / "images").iterdir())[:3]:
        shutil.copy(tiny_sample / "images" / name, images / name)
    seen = []
    run = RunContext(TINY_OPTIONS, lambda stage, fraction: seen.append((stage, fraction)))
    sfm.extract_features(images, tmp_path / "database.db", run)
    assert seen[0] == ("extract", 0.0) and seen[-1] == ("extract", 1.0)
    extracted = len(seen)
    sfm.match_features(tmp_path / "database.db", run)
    assert seen[extracted] == ("match", 0.0) and seen[-1] == ("match", 1.0)


@pytest.mark.parametrize(("images", "matcher"), [(57, "exhaustive"), (300, "exhaustive"),
                                                 (5, "exhaustive"), (300, "sequential")])
def test_matching_blocks_cover_every_pair_once_and_touch_few_images(images, matcher):
    pairs = sfm.candidate_pairs(list(range(1, images + 1)), matcher)
    blocks = sfm._blocks_of_images(pairs)
    assert sorted(p for block in blocks for p in block) == sorted(pairs)
    assert len(blocks) <= 2 * sfm.MATCH_CHUNKS
    if matcher == "exhaustive" and images > 20:
        # each call sees at most two blocks of images, not the whole set
        assert max(len({i for p in block for i in p}) for block in blocks) < 0.6 * images


def _cameras(database):
    # closed at once: a Python connection left open while COLMAP's own SQLite writes the same
    # file corrupts it (two SQLite libraries in one process do not see each other's locks)
    with closing(sqlite3.connect(database)) as conn:
        cameras = conn.execute("SELECT camera_id, width, height FROM cameras").fetchall()
        images = dict(conn.execute("SELECT name, camera_id FROM images"))
        frames = conn.execute("SELECT f.frame_id, r.ref_sensor_id, d.sensor_id FROM frames f "
                              "JOIN rigs r USING (rig_id) JOIN frame_data d USING (frame_id)").fetchall()
    return cameras, images, frames


def test_images_verify_with_a_camera_each_and_map_with_one_per_size(tiny_sample, tmp_path):
    """Landscape and portrait images end with one camera per size, rigs and frames following."""
    images = tmp_path / "images"
    images.mkdir()
    names = sorted(p.name for p in (tiny_sample / "images").iterdir())[:6]
    for name in names[:4]:
        shutil.copy(tiny_sample / "images" / name, images / name)
    for name in names[4:]:  # two portrait images: a different kind of image
        Image.open(tiny_sample / "images" / name).transpose(Image.Transpose.ROTATE_90).save(images / name)
    database = tmp_path / "database.db"
    sfm.extract_features(images, database, RunContext(TINY_OPTIONS))
    cameras, by_image, _ = _cameras(database)
    assert len(cameras) == 6  # one per image while verifying
    with closing(sqlite3.connect(database)) as conn:  # a GPS prior, as a phone photo brings
        conn.execute("INSERT INTO pose_priors VALUES (1, ?, ?, 0, NULL, NULL, NULL, 0)",
                     (2, by_image[names[1]]))
        conn.commit()

    sfm.match_features(database, RunContext(TINY_OPTIONS))
    cameras, by_image, frames = _cameras(database)
    with Image.open(images / names[0]) as img:
        landscape = img.size
    assert sorted((w, h) for _, w, h in cameras) == sorted([landscape, landscape[::-1]])
    sizes = {cid: (w, h) for cid, w, h in cameras}
    for name, camera_id in by_image.items():
        with Image.open(images / name) as img:
            assert sizes[camera_id] == img.size
    assert len(frames) == 6 and all(ref == sensor for _, ref, sensor in frames)
    with closing(sqlite3.connect(database)) as conn:
        prior_camera = conn.execute("SELECT corr_sensor_id FROM pose_priors").fetchone()[0]
    assert prior_camera == by_image[names[1]] in sizes  # it follows its image's joined camera
    assert colmap_db.share_cameras(database) == 0  # joining twice changes nothing
    # COLMAP reads the joined database as it wrote it
    loaded = pycolmap.Database.open(database)
    assert (loaded.num_cameras(), loaded.num_rigs(), loaded.num_images()) == (2, 2, 6)
    loaded.close()


def test_the_reconstructed_sample_has_one_camera(tiny_workspace_ro):
    model = Workspace(tiny_workspace_ro).load_models()[0]
    assert len(model.cameras) == 1


def test_hierarchical_mapping_is_selectable_and_maps_the_tiny_sample(tiny_workspace, monkeypatch):
    calls = []
    real = pycolmap.hierarchical_mapping

    def recorded(*args, **kwargs):  # the real mapper runs; the test only sees that it was chosen
        calls.append(args[3].num_threads)
        return real(*args, **kwargs)

    monkeypatch.setattr(pycolmap, "hierarchical_mapping", recorded)
    workspace = Workspace(tiny_workspace)
    options = SfmOptions(mapper="hierarchical", max_num_features=1024, num_threads=2)
    workspace.map_again(RunContext(options), cold=True)
    assert calls == [2] and workspace.load_models()[0].num_reg_images() >= 10


@pytest.mark.parametrize(("count", "models_after"), [
    (sfm.LARGE_MAP_ABOVE_IMAGES, 2),      # a small capture keeps COLMAP's models as before
    (sfm.LARGE_MAP_ABOVE_IMAGES + 1, 1),  # a large one joins those sharing images
])
def test_a_large_cold_map_joins_sub_models_that_share_images(count, models_after, tmp_path,
                                                              monkeypatch):
    from tests.core.test_group_pose import OTHER, SWAYING, _model

    split = {0: _model(SWAYING), 1: _model(SWAYING[2:] + OTHER)}
    monkeypatch.setattr(sfm, "_incremental_map", lambda *args: split)
    monkeypatch.setattr(colmap_db, "image_names", lambda _: {i: f"{i}.png" for i in range(count)})
    models = sfm.map_database(tmp_path / "database.db", tmp_path, tmp_path / "sparse")
    assert len(models) == models_after
    assert sorted(p.name for p in (tmp_path / "sparse").iterdir()) == [str(i) for i in range(models_after)]
    assert models[0].num_reg_images() == (len(SWAYING) + len(OTHER) if models_after == 1 else 7)


@pytest.mark.parametrize(("count", "ratio"), [
    (sfm.LARGE_MAP_ABOVE_IMAGES, pycolmap.IncrementalPipelineOptions().ba_global_frames_ratio),
    (sfm.LARGE_MAP_ABOVE_IMAGES + 1, sfm.LARGE_GLOBAL_BA_RATIO),
])
def test_a_large_cold_map_runs_sparser_global_adjustments(count, ratio, tmp_path, monkeypatch):
    seen = []

    def mapper(database, image_dir, out, mapping, **kwargs):
        seen.append((mapping.ba_global_frames_ratio, mapping.ba_global_points_ratio))
        return {}

    monkeypatch.setattr(pycolmap, "incremental_mapping", mapper)
    sfm._incremental_map(tmp_path / "database.db", tmp_path, str(tmp_path), RunContext(), None,
                         False, count)
    assert seen and all(pair == pytest.approx((ratio, ratio)) for pair in seen)


LARGE = sfm.LARGE_MAP_ABOVE_IMAGES + 100  # 200 images: a large capture
SMALL = sfm.LARGE_MAP_ABOVE_IMAGES        # 100 images: the small path


@pytest.mark.parametrize(("registered", "num_images", "retry"), [
    ([range(0, 99), range(100, 199)], LARGE, False),  # two legs, 99 + 99 of 200: the capture splits
    ([range(0, 99), range(90, 190)], LARGE, False),   # legs sharing images (hall-300's far turn)
    ([range(0, 5)], LARGE, True),                     # a dead-end start: most images in no model
    ([range(0, 40), range(50, 60)], LARGE, True),     # together still under half
    ([range(0, 100)], LARGE, False),                  # the largest holds half: done
    ([], LARGE, True),                                # nothing registered
    ([range(0, 49), range(50, 99)], SMALL, True),     # small captures keep the first rule
    ([range(0, 50)], SMALL, False),
])
def test_a_cold_start_is_retried_only_where_another_seed_can_help(registered, num_images, retry):
    assert sfm.cold_start_worth_retrying([set(ids) for ids in registered], num_images) is retry


class _Registered:
    """What the retry loop reads of a model: its registered image ids."""

    def __init__(self, ids):
        self.ids = list(ids)

    def num_reg_images(self):
        return len(self.ids)

    def reg_image_ids(self):
        return self.ids


@pytest.mark.parametrize(("count", "split", "starts"), [
    (LARGE, [range(0, 99), range(100, 199)], 1),  # a structural split maps once
    (LARGE, [range(0, 5)], sfm.COLD_START_ATTEMPTS),  # a dead end starts again
    (SMALL, [range(0, 49), range(50, 99)], sfm.COLD_START_ATTEMPTS),  # the small path unchanged
])
def test_a_cold_map_split_by_the_capture_itself_maps_once(count, split, starts, tmp_path,
                                                          monkeypatch):
    seeds = []

    def mapper(database, image_dir, out, mapping, **kwargs):
        seeds.append(mapping.random_seed)
        return {i: _Registered(ids) for i, ids in enumerate(split)}

    monkeypatch.setattr(pycolmap, "incremental_mapping", mapper)
    models = sfm._incremental_map(tmp_path / "database.db", tmp_path, str(tmp_path), RunContext(),
                                  None, False, count)
    assert len(seeds) == len(set(seeds)) == starts
    assert sorted(m.num_reg_images() for m in models.values()) == sorted(map(len, split))
