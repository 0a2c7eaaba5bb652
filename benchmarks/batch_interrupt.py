"""How long ``autorig batch`` takes to stop on Ctrl-C while its workers are deep in a rig.

    python benchmarks/batch_interrupt.py [--shared ../shared] [--mesh horse] [--after 5] [--runs 3]

A temporary folder (never in the repo) of four copies of ``shared/data/meshes/MESH.obj`` is rigged with
``autorig batch -j 2 --template quadruped`` in its own session; ``--after`` seconds later SIGINT goes to the whole
process group, as a terminal's Ctrl-C does. Printed per run: the seconds from the signal to the process's exit,
its exit code (130 expected) and how many of its child processes (the workers and multiprocessing's resource
tracker) still run a second later (zombies not counted: their end is over, only not yet reaped).
"""
from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def children(pid: int) -> set[int]:
    """The process ids of ``pid``'s children (Linux /proc)."""
    found = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return found


def running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (one whose end its new parent has not yet reaped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", default=str(Path(__file__).resolve().parents[2] / "shared"))
    parser.add_argument("--mesh", default="horse")
    parser.add_argument("--after", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    mesh = Path(args.shared, "data", "meshes", f"{args.mesh}.obj")
    autorig = Path(sys.executable).with_name("autorig")
    with tempfile.TemporaryDirectory() as tmp:
        assets = Path(tmp, "assets")
        assets.mkdir()
        for k in range(4):
            shutil.copyfile(mesh, assets / f"{args.mesh}{k}.obj")
        for run in range(args.runs):
            out = Path(tmp, "out")
            shutil.rmtree(out, ignore_errors=True)
            process = subprocess.Popen([str(autorig), "batch", str(assets), "-o", str(out), "-j", "2", "--template",
                                        "quadruped"], start_new_session=True, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.PIPE)
            time.sleep(args.after)
            workers = children(process.pid)
            start = time.monotonic()
            os.killpg(process.pid, signal.SIGINT)
            _, stderr = process.communicate()
            seconds = time.monotonic() - start
            time.sleep(1.0)
            alive = [pid for pid in workers if running(pid)]
            for pid in alive:
                print("  alive:", Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")[:120].decode())
            print(f"run {run + 1}: stopped {seconds:.2f} s after SIGINT, exit {process.returncode}, "
                  f"{len(workers)} children before, {len(alive)} running 1 s after; {stderr.decode().strip()[-60:]!r}")


if __name__ == "__main__":
    main()
