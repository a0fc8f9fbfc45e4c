"""Seconds and peak memory per stage, from progress reports."""

import sys
import time

import numpy as np
import pytest

from guided_sfm.core import stage_clock
from guided_sfm.core.stage_clock import StageClock, format_report


def run_stages(seen: list) -> dict:
    """extract holds 400 MiB, match and scene hold nothing more; the clock's report."""
    clock = StageClock(lambda stage, fraction: seen.append((stage, fraction)))
    clock("extract", 0.0)
    big = np.ones(400 * 2**20 // 8)  # 400 MiB, touched, in "extract" only
    time.sleep(0.05)
    clock("extract", 1.0)
    del big
    clock("match", 0.5)
    time.sleep(0.02)
    with clock.timed("scene"):
        time.sleep(0.01)
    return clock.report()


def test_each_stage_gets_its_own_time_and_peak_memory():
    seen = []
    report = run_stages(seen)
    stages = {s["stage"]: s for s in report["stages"]}
    assert list(stages) == ["extract", "match", "scene"]
    assert seen == [("extract", 0.0), ("extract", 1.0), ("match", 0.5)]  # reports pass through
    assert stages["extract"]["seconds"] >= 0.05 and stages["match"]["seconds"] >= 0.02
    assert stages["extract"]["peak_mb"] >= 400
    assert report["peak_mb"] == stages["extract"]["peak_mb"]
    assert abs(report["seconds"] - sum(s["seconds"] for s in stages.values())) < 0.02
    assert format_report(report)[-1][0] == "time total"


@pytest.mark.skipif(sys.platform != "linux", reason="only Linux restarts the high-water mark")
def test_a_later_stage_does_not_inherit_an_earlier_peak():
    assert stage_clock.reset_peak_memory()  # /proc/self/clear_refs takes "5" on every Linux we run
    stages = {s["stage"]: s for s in run_stages([])["stages"]}
    assert stages["match"]["peak_mb"] < stages["extract"]["peak_mb"] - 300


def test_take_returns_seconds_and_starts_afresh():
    clock = StageClock()
    clock("map", 0.0)
    assert set(clock.take()) == {"map"}
    assert clock.take() == {} and clock.report()["stages"] == []
