"""Apply each mutation (a *.patch here) to a scratch copy of the tracked files and run the tests that
should catch it; a mutation survives when those tests pass. Not collected by pytest, not in CI.

    python tests/mutations/run.py [name-substring ...]

Each patch starts with header lines before its diff:
    catch: tests/api/test_x.py::test_y   (one or more; pytest node ids run on the mutated copy)
    why: one line saying what the mutation breaks
    env: NAME=value   (optional; e.g. the Postgres URL for a test that only holds there)
Exit status: 0 when every mutation is caught, 1 when any survives or fails to apply.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent


def header(patch: Path, key: str) -> list[str]:
    values = []
    for line in patch.read_text().splitlines():
        if line.startswith("diff --git"):
            break
        if line.startswith(f"{key}:"):
            values.append(line.split(":", 1)[1].strip())
    return values


def scratch_copy(target: Path) -> None:
    """The working tree's files that git tracks or would track (uncommitted ones too)."""
    listing = ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"]
    names = subprocess.run(listing, cwd=ROOT, check=True, capture_output=True).stdout
    for name in filter(None, names.decode().split("\0")):
        source = ROOT / name
        if source.is_file():
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / name)


def stop_leftovers(copy: Path) -> None:
    """Kill what a mutant left running: a server the tests started in a session of its own outlives
    pytest when the mutant breaks its shutdown. Such processes run from the copy or import from it."""
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            cwd = os.readlink(proc / "cwd")
            environ = (proc / "environ").read_bytes()
        except OSError:  # gone, or not ours to read
            continue
        if cwd.startswith(str(copy)) or f"PYTHONPATH={copy}".encode() in environ:
            with contextlib.suppress(OSError):
                os.kill(int(proc.name), signal.SIGKILL)


def run_one(patch: Path) -> tuple[str, str, float]:
    """(result, detail, seconds) for one mutation: caught, SURVIVED or NOT APPLIED."""
    tests = header(patch, "catch")
    with tempfile.TemporaryDirectory(prefix="mutant-") as tmp:
        copy = Path(tmp)
        scratch_copy(copy)
        applied = subprocess.run(["git", "apply", str(patch)], cwd=copy, capture_output=True, text=True)
        if applied.returncode != 0:
            return "NOT APPLIED", applied.stderr.strip(), 0.0
        env = {**os.environ, "PYTHONPATH": f"{copy / 'services'}{os.pathsep}{copy}",
               **dict(line.split("=", 1) for line in header(patch, "env"))}
        start = time.monotonic()
        result = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
                                 *tests], cwd=copy, env=env, capture_output=True, text=True)
        seconds = time.monotonic() - start
        stop_leftovers(copy)
    last = ((result.stdout + result.stderr).strip().splitlines() or [""])[-1]
    if result.returncode == 1:  # 1: tests ran and some failed
        return "caught", last, seconds
    return "SURVIVED" if result.returncode == 0 else f"ERROR rc={result.returncode}", last, seconds


def main(filters: list[str]) -> int:
    patches = sorted(p for p in HERE.glob("*.patch") if not filters or any(f in p.name for f in filters))
    failures = 0
    print("| mutation | catching test | result |\n|---|---|---|")
    for patch in patches:
        result, detail, seconds = run_one(patch)
        failures += result != "caught"
        tests = "<br>".join(header(patch, "catch"))
        print(f"| {patch.stem}: {' '.join(header(patch, 'why'))} | {tests} | {result} "
              f"({seconds:.0f} s; {detail}) |", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
