"""Seconds and peak memory per stage of a long piece of work, taken from its progress reports."""

from __future__ import annotations

import resource
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from guided_sfm.core.types import Progress, no_progress

STATUS = Path("/proc/self/status")
CLEAR_REFS = Path("/proc/self/clear_refs")


def reset_peak_memory() -> bool:
    """Restart the process's resident-memory high-water mark (Linux); False where it cannot."""
    try:
        CLEAR_REFS.write_text("5")
        return True
    except OSError:
        return False


def peak_memory_mb() -> float:
    """The process's resident-memory high-water mark since start or the last reset, in MiB."""
    try:
        for line in STATUS.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # Linux reports KiB


class StageClock:
    """A progress callback that passes reports on and measures each stage it sees.

    A stage runs from its first report to the first report of another stage. Peak memory is the
    process's high-water mark, restarted at each stage (where the kernel allows it; otherwise each
    figure is the peak so far), so one job's figures are not another's.
    """

    def __init__(self, progress: Progress = no_progress) -> None:
        self.progress = progress
        self.seconds: dict[str, float] = {}
        self.peak_mb: dict[str, float] = {}
        self._stage, self._since = "", 0.0

    def __call__(self, stage: str, fraction: float) -> None:
        if stage != self._stage:
            self._stop()
            self._start(stage)
        self.progress(stage, fraction)

    def _start(self, stage: str) -> None:
        reset_peak_memory()
        self._stage, self._since = stage, time.perf_counter()

    def _stop(self) -> None:
        if self._stage:
            stage = self._stage
            self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - self._since
            self.peak_mb[stage] = max(self.peak_mb.get(stage, 0.0), peak_memory_mb())
        self._stage = ""

    @contextmanager
    def timed(self, stage: str) -> Iterator[None]:
        """Measure a block that reports no progress of its own as one stage."""
        self._stop()
        self._start(stage)
        try:
            yield
        finally:
            self._stop()

    def report(self) -> dict:
        """{"stages": [{stage, seconds, peak_mb}], "seconds", "peak_mb"} of what was measured."""
        self._stop()
        stages = [{"stage": stage, "seconds": round(seconds, 2), "peak_mb": round(self.peak_mb[stage])}
                  for stage, seconds in self.seconds.items()]
        return {"stages": stages, "seconds": round(sum(self.seconds.values()), 2),
                "peak_mb": max((s["peak_mb"] for s in stages), default=0)}

    def take(self) -> dict[str, float]:
        """Seconds per stage so far (rounded), then start afresh."""
        self._stop()
        taken = {stage: round(seconds, 1) for stage, seconds in self.seconds.items()}
        self.seconds, self.peak_mb = {}, {}
        return taken


def format_report(report: dict) -> list[tuple[str, str]]:
    """Table rows for a report: one per stage, then the total."""
    rows = [(f"time {s['stage']}", f"{s['seconds']:.1f} s, peak {s['peak_mb']} MiB")
            for s in report["stages"]]
    rows.append(("time total", f"{report['seconds']:.1f} s, peak {report['peak_mb']} MiB"))
    return rows
