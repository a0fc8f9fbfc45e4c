"""The rule's model parts are kept between previews, and read again once the model is rewritten."""

import os

from guided_sfm.core.rule.evidence import model_parts
from tests.core.test_topdown import HAND_MADE, _model


def test_model_parts_are_kept_until_the_files_change(tmp_path):
    folder = tmp_path / "0"
    folder.mkdir()
    _model(HAND_MADE).write_binary(folder)
    first = model_parts(folder)
    assert model_parts(folder) is first  # the same version's preview again: nothing re-read
    moved = [(name, image_id, (x + 1.0, y, z), yaw) for name, image_id, (x, y, z), yaw in HAND_MADE]
    _model(moved).write_binary(folder)
    stat = (folder / "images.bin").stat()
    os.utime(folder / "images.bin", ns=(stat.st_atime_ns, stat.st_mtime_ns + 1))  # same-tick write
    second = model_parts(folder)
    assert second is not first
    assert abs(second.poses[3].center[0] - first.poses[3].center[0] - 1.0) < 1e-6
    assert set(second.cameras) == {1, 2, 3} and len(second.points[0]) == len(first.points[0])
