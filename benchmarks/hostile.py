"""Hostile files (issue 42): each family of ``tests/hostile_files.py`` generated into a temporary folder and
rigged by the command line in a process of its own; prints its exit code, first line of stderr, wall time and
peak memory (the child's max RSS: /usr/bin/time's where installed, else wait4's, which Linux starts at this
script's own size at the fork), and says which families break the bound (30 s, 2 GB) or end
in an exit code they should not.

    python benchmarks/hostile.py                    # every family
    python benchmarks/hostile.py soup-600 gltf-     # families whose name starts with one of these
    python benchmarks/hostile.py --timeout 60       # kill a case after 60 s (default 120)
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from hostile_files import FAMILIES, NEEDS_ROOT  # noqa: E402

BOUND_SECONDS, BOUND_BYTES = 30.0, 2 << 30


def run(args: list[str], timeout: float) -> tuple[int | None, str, float, int]:
    """(exit code or None if killed, first stderr line, wall seconds, max RSS bytes) of ``autorig ARGS``."""
    autorig = Path(sys.executable).with_name("autorig")
    command = [str(autorig)] if autorig.exists() else [sys.executable, "-m", "autorig.cli"]
    timer = Path("/usr/bin/time")
    if timer.exists():
        command = [str(timer), "-f", "autorig-max-rss-kb %M"] + command
    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        process = subprocess.Popen(command + args, stdout=subprocess.DEVNULL, stderr=err, stdin=subprocess.DEVNULL)
        while True:
            pid, status, usage = os.wait4(process.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() - start > timeout:
                process.kill()
                pid, status, usage = os.wait4(process.pid, 0)
                break
            time.sleep(0.02)
        wall = time.perf_counter() - start
        process.returncode = 0  # reaped by wait4 above
        err.seek(0)
        lines = err.read().decode("utf-8", "replace").splitlines()
    rss = usage.ru_maxrss * 1024
    timed = [line for line in lines if line.startswith("autorig-max-rss-kb ")]
    if timed:
        rss = int(timed[-1].split()[1]) * 1024
    lines = [line for line in lines if not line.startswith(("autorig-max-rss-kb ", "Command exited", "Command terminated"))]
    code = os.waitstatus_to_exitcode(status)
    return (None if code < 0 else code), (lines[0] if lines else ""), wall, rss


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("only", nargs="*", help="run only families whose name starts with one of these")
    parser.add_argument("--timeout", type=float, default=120.0)
    given = parser.parse_args()
    bad = 0
    print(f"{'family':28} {'exit':>4} {'wall s':>7} {'max RSS':>8}  first line")
    for name, make in FAMILIES.items():
        if given.only and not any(name.startswith(p) for p in given.only):
            continue
        if name in NEEDS_ROOT and os.geteuid() != 0:
            print(f"{name:28} skipped (needs root for mknod)")
            continue
        folder = Path(tempfile.mkdtemp(prefix=f"autorig-hostile-{name}-"))
        try:
            args, exits = make(folder / "case")
            code, line, wall, rss = run(args, given.timeout)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        wrong = code not in exits or wall > BOUND_SECONDS or rss > BOUND_BYTES
        bad += wrong
        shown = line if len(line) <= 110 else line[:107] + "..."
        print(f"{name:28} {'kill' if code is None else code:>4} {wall:7.1f} {rss / 2**20:6.0f} MB  "
              f"{'!! ' if wrong else ''}{shown}", flush=True)
    print(f"{bad} famil{'y' if bad == 1 else 'ies'} outside the bounds or the expected exit codes")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
