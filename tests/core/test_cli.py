"""The command line as scripts use it: exit codes, one-line errors, JSON on stdout, no writes."""

import json
import subprocess
import sys
import time

import pytest


def run(*args, check=False):
    done = subprocess.run([sys.executable, "-m", "guided_sfm.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)
    if check:
        assert done.returncode == 0, done.stderr
    return done


def test_sample_lists_layouts():
    names = run("sample", "x", "--layout", "list", check=True).stdout.split()
    assert {"murals", "tiny"} <= set(names)


@pytest.mark.parametrize(
    ("edits", "message"),
    [
        ("{not json", "not valid JSON"),
        ('{"cameras": [{"name": "nope.jpg", "x": 0, "y": 0, "yaw_deg": 0}]}', "unknown image"),
        ('{"cameras": [{"image_id": 1, "x": 0, "y": 0, "yaw_deg": 0, "fov_deg": 180}]}', "fov"),
        ('{"cameras": [{"image_id": 1, "x": "a", "y": 0, "yaw_deg": 0}]}', "finite number"),
    ],
)
def test_prune_rejects_bad_edits_and_writes_nothing(tiny_workspace, tmp_path, edits, message):
    edits_file = tmp_path / "edits.json"
    edits_file.write_text(edits)
    done = run("prune", tiny_workspace, edits_file, tmp_path / "new")
    assert done.returncode == 1
    assert done.stderr.strip().count("\n") == 0 and message in done.stderr
    assert not (tmp_path / "new").exists()


def test_missing_workspace_is_one_line(tmp_path):
    done = run("scene", tmp_path / "missing", "--json")
    assert done.returncode == 1 and "not a workspace" in done.stderr
    assert done.stderr.strip().count("\n") == 0


def test_prune_dry_run_json_names_pairs_and_writes_nothing(tiny_workspace, tmp_path):
    scene = json.loads(run("scene", tiny_workspace, "--json", check=True).stdout)
    camera = [c for c in scene["cameras"] if c["registered"]][0]
    edits = {"cameras": [{"name": camera["name"], "x": 1e4, "y": 1e4, "yaw_deg": 0}],
             "rule": "paper"}
    (tmp_path / "e.json").write_text(json.dumps(edits))
    done = run("prune", tiny_workspace, tmp_path / "e.json", tmp_path / "new", "--dry-run",
               "--json", check=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["deleted_pairs"] and all(camera["name"] in p for p in result["deleted_pairs"])
    assert all(p == sorted(p) for p in result["deleted_pairs"])
    assert result["deleted_pairs"] == sorted(result["deleted_pairs"])
    assert result["components_after"] >= 1 and "removed_by_test" in result
    assert result["kept_to_connect"] == []  # the paper's rule keeps nothing
    assert not (tmp_path / "new").exists()


def test_scene_png_after_pycolmap_import_does_not_crash(tiny_workspace, tmp_path):
    """Regression guard: Pillow saving a PNG after pycolmap was imported aborted the process."""
    run("scene", tiny_workspace, "--png", tmp_path / "scene.png", check=True)
    assert (tmp_path / "scene.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_map_reports_each_stage_with_its_time_and_peak_memory(tiny_workspace, tmp_path):
    (tmp_path / "e.json").write_text(json.dumps({"cameras": []}))
    run("prune", tiny_workspace, tmp_path / "e.json", tmp_path / "new", check=True)
    start = time.monotonic()
    lines = run("map", tmp_path / "new", check=True).stdout.splitlines()
    elapsed = time.monotonic() - start
    # rows such as "time map    1.2 s, peak 412 MiB"
    times = {" ".join(line.split()[:2]): line.split()[2:] for line in lines if line.startswith("time ")}
    assert {"time map", "time total"} <= set(times)
    seconds, _, _, peak, unit = times.pop("time total")
    stages = [float(row[0]) for row in times.values()]
    # the total is the stages' sum (each printed to 0.1 s) and fits in the process's wall time
    assert abs(float(seconds) - sum(stages)) <= 0.05 * (len(stages) + 1) and unit == "MiB"
    assert 0 <= float(seconds) <= elapsed
    assert int(peak) == max(int(row[3]) for row in times.values())  # the total's peak is the stages' max
    assert int(peak) > 50  # pycolmap and numpy alone hold more than 50 MiB


def test_reconstruct_table_names_the_matcher_auto_chose_the_mapper_and_the_image_size(tiny_sample,
                                                                                       tmp_path):
    done = run("reconstruct", tiny_sample / "images", tmp_path / "ws", "--threads", "2",
               "--max-image-size", "0", check=True)
    rows = dict(line.split(None, 1) for line in done.stdout.splitlines() if line.strip())
    assert rows["matcher"] == "auto: exhaustive" and rows["mapper"] == "incremental"
    assert rows["max_image_size"] == "3200"  # 0: COLMAP's own


def test_suspects_names_images_and_ends_with_the_json_document(tiny_workspace):
    table = run("suspects", tiny_workspace, check=True)
    document = json.loads(table.stdout.strip().splitlines()[-1])
    assert table.stdout.startswith("suspects")  # a readable summary before the document
    as_json = run("suspects", tiny_workspace, "--json", check=True)
    assert json.loads(as_json.stdout) == document
    from guided_sfm.core.workspace import Workspace

    image_names = set(Workspace(tiny_workspace).image_names().values())
    assert {s["name"] for s in document["suspects"]} == image_names
    assert all(set(s) == {"name", "score", "reasons"} for s in document["suspects"])
    for run_ in document["runs"]:
        assert set(run_["names"]) <= image_names
        assert [c["name"] for c in run_["proposal"]["cameras"]] == run_["names"]


def test_a_proposal_is_an_edit_set_prune_takes(tiny_workspace, tmp_path):
    document = json.loads(run("suspects", tiny_workspace, "--json", check=True).stdout)
    edits = tmp_path / "edits.json"
    edits.write_text(json.dumps({"cameras": document["runs"][0]["proposal"]["cameras"]}))
    done = run("prune", tiny_workspace, edits, tmp_path / "new", "--dry-run", "--json", check=True)
    assert json.loads(done.stdout.splitlines()[-1])["deleted_pairs"]


@pytest.mark.parametrize(("argv", "size"), [([], 1600), (["--max-image-size", "1024"], 1024),
                                            (["--max-image-size", "0"], None)])
def test_reconstruct_takes_the_max_image_size(argv, size):
    from guided_sfm.cli import _options, build_parser
    from guided_sfm.core.sfm import DEFAULT_MAX_IMAGE_SIZE

    args = build_parser().parse_args(["reconstruct", "images", "workspace", *argv])
    assert _options(args).max_image_size == size and DEFAULT_MAX_IMAGE_SIZE == 1600
