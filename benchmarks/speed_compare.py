"""Two installs of autorig side by side in one run: whole-process time and peak memory, and the same rigs.

    python benchmarks/speed_compare.py --old /path/to/old-venv/bin/python [--new PYTHON] [--runs 5]
        [--sizes 20000,60000] [--meshes mannequin,armadillo] [--shared ../shared] [--no-time] [--no-rigs]

Each side is a Python whose ``autorig`` is one commit's editable install (each side needs its own venv: the
templates resolve through the install). Made for "is the new commit faster, and does it rig the same":

- time: the meshes of ``benchmarks/speed.py`` (built once), each rigged as a user runs it (a fresh
  ``autorig MESH -o OUT.glb`` process, axes detected) by old and new in turn, alternating which goes first, so
  that load from other work on the machine falls on both alike. Printed per side: median wall time, median CPU
  time (user + system) of the autorig process with its children and of the process alone ("main": what stays
  on its path when work moves to a child on another core), peak RSS; the ratios new / old, and the load
  average after each mesh (above the CPU count, the wall times mostly measure the wait for a core).
- rigs: every shared mesh (``shared/data/meshes/*.obj`` and ``shared/data/rigged/*/mesh.obj``, with the
  template and axes ``benchmarks/batch_speed.py`` gives them) rigged by both sides to JSON. Per mesh: the
  largest joint distance between the two rigs as a fraction of the mesh's height (its extent along the up
  axis), and the share of vertices whose heaviest joint differs. Same rig: joints within 1e-3 of the height
  and at most 0.5 % of vertices with another heaviest joint (or both sides fail alike).

Exit code 0 when every mesh rigs the same, 1 otherwise.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from batch_speed import CONFIG  # noqa: E402  (the benchmarks are scripts, not a package)
from speed import FORK_AND_EXEC, USER_ENV, build_meshes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOINT_TOLERANCE = 1e-3   # of the height
TOP1_TOLERANCE = 0.005   # share of vertices
# Every side runs from a folder without an autorig package in it: "python -c" and "-m" put the working folder
# first on sys.path, which would make both sides import the checkout the benchmark is started from.
NEUTRAL = tempfile.gettempdir()


# As benchmarks/speed.py's launcher, plus CPU times (user + system): of the autorig process and the children it
# waited for, and of the autorig process alone ("main": read from /proc while it is a zombie, before it is
# reaped). On a machine busy with other work the wall time mostly measures the wait for a core; the main
# process's CPU time is what remains on its path when work moves to a child process on another core.
LAUNCHER = FORK_AND_EXEC + """os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT)
wall = time.perf_counter() - start
fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
main = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")   # utime + stime, the process alone
_, status, usage = os.wait4(pid, 0)
print(wall, usage.ru_utime + usage.ru_stime, main, usage.ru_maxrss // 1024, os.waitstatus_to_exitcode(status))
"""


def timed(python: str, args: list[str]) -> tuple[float, float, float, int]:
    """(wall seconds, CPU seconds with children, CPU seconds of the process alone, peak RSS in MB) of one
    ``autorig`` process run by ``python``."""
    done = subprocess.run([python, "-c", LAUNCHER, *args], capture_output=True, text=True, env=USER_ENV,
                          cwd=NEUTRAL)
    seconds, cpu, main, rss, code = done.stdout.split()
    if int(code):
        raise RuntimeError(f"{python} -m autorig {' '.join(args)} failed: {done.stderr.strip()}")
    return float(seconds), float(cpu), float(main), int(rss)


def compare_time(sides: dict[str, str], sizes: list[int], names: set[str], runs: int, shared: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        meshes = [m for m in build_meshes(folder, sizes, shared) if m[0] in names]
        for python in sides.values():   # warm-up: bytecode and file caches
            timed(python, [str(meshes[0][2]), "-o", str(folder / "out.glb")])
        print(f"{'mesh':10s} {'faces':>8s} " + " ".join(f"{s + ' s':>7s} {s + ' cpu':>8s} {s + ' main':>8s} "
                                                     f"{s + ' MB':>7s}" for s in sides)
              + "   new/old: wall    cpu   main  load")
        for name, size, path, flags in meshes:
            results: dict[str, list[tuple[float, float, float, int]]] = {side: [] for side in sides}
            for run in range(runs if size < 1_000_000 else max(1, (runs + 1) // 2)):
                order = list(sides) if run % 2 == 0 else list(sides)[::-1]
                for side in order:
                    results[side].append(timed(sides[side], [str(path), "-o", str(folder / f"{side}.glb"), *flags]))
            median = {side: [statistics.median(r[k] for r in rs) for k in range(3)] for side, rs in results.items()}
            rss = {side: max(r[3] for r in rs) for side, rs in results.items()}
            ratios = [median["new"][k] / median["old"][k] for k in range(3)]
            print(f"{name:10s} {size:8d} " + " ".join(f"{median[s][0]:7.2f} {median[s][1]:8.2f} {median[s][2]:8.2f} "
                                                     f"{rss[s]:7d}" for s in sides)
                  + "            " + " ".join(f"{r:6.2f}" for r in ratios) + f"  {os.getloadavg()[0]:4.1f}",
                  flush=True)


def shared_meshes(shared: Path) -> list[tuple[str, Path, list[str]]]:
    """(name as batch_speed.py's folder has it, path, template and axis flags) of every shared mesh."""
    config = tomllib.loads(CONFIG)
    data = shared / "data"
    found = [(p.name, p) for p in sorted((data / "meshes").glob("*.obj"))]
    found += [(f"rigged/{p.parent.name}.obj", p) for p in sorted((data / "rigged").glob("*/mesh.obj"))]
    out = []
    for name, path in found:
        options = {k: config[k] for k in ("template", "up", "front")} | config["files"].get(name, {})
        out.append((name, path, [f for k, v in options.items() for f in (f"--{k}", str(v))]))
    return out


def rig_json(python: str, mesh: Path, flags: list[str], out: Path) -> dict | str:
    """The JSON rig written by ``python -m autorig.cli``, or its error line when it fails."""
    done = subprocess.run([python, "-m", "autorig.cli", str(mesh), "-o", str(out), "-q", *flags],
                          capture_output=True, text=True, env=USER_ENV, cwd=NEUTRAL)
    if done.returncode:
        return done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit {done.returncode}"
    return json.loads(out.read_text())


def dense_weights(rig: dict) -> np.ndarray:
    """[V, J] weights of a JSON rig."""
    table = rig["weights"]
    W = np.zeros((table["vertex_count"], len(table["joint_names"])))
    for v, (joints, weights) in enumerate(table["rows"]):
        W[v, joints] = weights
    return W


def compare_rigs(sides: dict[str, str], shared: Path) -> bool:
    from autorig.input.mesh import load_mesh
    axis = {"x": 0, "y": 1, "z": 2}
    print(f"\n{'mesh':28s} {'joints/height':>13s} {'top-1 moved':>11s} {'max |dw|':>9s}  same")
    every = True
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, flags in shared_meshes(shared):
            rigs = {side: rig_json(python, path, flags, Path(tmp, f"{side}.json")) for side, python in sides.items()}
            old, new = rigs["old"], rigs["new"]
            if isinstance(old, str) or isinstance(new, str):
                same = isinstance(old, str) and isinstance(new, str)
                print(f"{name:28s} {'failed' if isinstance(old, str) else 'rigged':>13s} -> "
                      f"{'failed' if isinstance(new, str) else 'rigged'}  {same}")
                every &= same
                continue
            V, _ = load_mesh(path)
            up = flags[flags.index("--up") + 1]
            height = float(np.ptp(V[:, axis[up.lstrip("-")]]))
            J_old = np.array([j["position"] for j in old["joints"]])
            J_new = np.array([j["position"] for j in new["joints"]])
            joint_error = float(np.linalg.norm(J_old - J_new, axis=1).max()) / height
            W_old, W_new = dense_weights(old), dense_weights(new)
            moved = float(np.mean(W_old.argmax(axis=1) != W_new.argmax(axis=1)))
            same = joint_error <= JOINT_TOLERANCE and moved <= TOP1_TOLERANCE
            every &= same
            print(f"{name:28s} {joint_error:13.2e} {100 * moved:10.2f}% {np.abs(W_old - W_new).max():9.2e}  {same}",
                  flush=True)
    print(f"\nsame rigs on every shared mesh: {every}")
    return every


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", required=True, help="the Python of the old commit's venv")
    parser.add_argument("--new", default=sys.executable, help="the Python of the new commit's venv (default: this one)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--sizes", default="20000,60000")
    parser.add_argument("--meshes", default="mannequin,armadillo", help="of mannequin, armadillo, horse")
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--no-time", action="store_true")
    parser.add_argument("--no-rigs", action="store_true")
    args = parser.parse_args(argv)
    sides = {"old": args.old, "new": args.new}
    for side, python in sides.items():
        where = subprocess.run([python, "-c", "import autorig; print(autorig.__file__)"], capture_output=True,
                               text=True, check=True, cwd=NEUTRAL).stdout.strip()
        print(f"{side}: {python} -> {where}")
    if not args.no_time:
        compare_time(sides, [int(s) for s in args.sizes.split(",")], set(args.meshes.split(",")), args.runs,
                     args.shared)
    return 0 if args.no_rigs or compare_rigs(sides, args.shared) else 1


if __name__ == "__main__":
    sys.exit(main())
