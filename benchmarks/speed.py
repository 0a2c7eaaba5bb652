"""Whole-process speed and memory of `autorig MESH`, as a user runs it, from 5k to 1M faces.

    python benchmarks/speed.py [--runs 5] [--sizes 5000,20000,60000,200000,1000000] [--shared ../shared]
                               [--templates humanoid,...]

Meshes: the project's mannequin (autorig.samples, A-pose) and, when ../shared/data is present, armadillo.obj
and horse.obj, each brought to every size by loop subdivision then quadric decimation to the exact face
count (built once into a temporary folder). Every run is a fresh `autorig MESH -o OUT.glb -v` process with
the default options (orientation detected), after one untimed warm-up run, timed from outside; peak RSS is that process's own (wait4).
Printed: the median wall time of the runs (fork to exit of the autorig process), the median of each stage's
time (from -v), the time outside every stage (the total less the stages' medians: starting Python, the
imports a rig needs, the command line; the floor no stage's speed-up reaches), the peak RSS, and
per stage the exponent b of time ~ faces^b fitted over the sizes. Also `autorig --help` / `--version`.
``--templates`` also rigs the mannequin with each of those templates (rows ``mannequin-NAME``), e.g. the
humanoid against the biped on the same meshes.
"""
from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def sized(vertices: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """The mesh subdivided until it has at least ``target`` faces, then decimated to exactly ``target``."""
    import fast_simplification
    import trimesh
    while len(faces) < target:
        vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    if len(faces) > target:
        vertices, faces = fast_simplification.simplify(vertices, faces.astype(np.int32), target_count=target)
    return np.asarray(vertices, float), np.asarray(faces, np.int64)


def build_meshes(folder: Path, sizes: list[int], shared: Path) -> list[tuple[str, int, Path, list[str]]]:
    """(name, faces, path, extra CLI flags) for every benchmark mesh, written as OBJ into ``folder``."""
    import trimesh
    from autorig.input.mesh import load_mesh
    from autorig.samples import mannequin
    sources = [("mannequin", mannequin(pose="a"), [])]
    for name in ("armadillo", "horse"):
        path = shared / "data" / "meshes" / f"{name}.obj"
        if path.is_file():
            V, F = load_mesh(path)
            sources.append((name, (V, F), ["--template", "horse"] if name == "horse" else []))
    out = []
    for name, source, flags in sources:
        V, F = (source.vertices, source.faces) if hasattr(source, "vertices") else source
        for size in sizes:
            path = folder / f"{name}_{size}.obj"
            v, f = sized(V, F, size)
            trimesh.Trimesh(v, f, process=False).export(path)
            out.append((name, size, path, flags))
    return out


# A fresh, small Python forks and execs autorig and reports the child's peak RSS: wait4 in this process
# would count the pages a fork inherits from it, and it holds the benchmark meshes.
FORK_AND_EXEC = """
import os, sys, time
start = time.perf_counter()
pid = os.fork()
if pid == 0:
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    os.execv(sys.executable, [sys.executable, "-m", "autorig.cli", *sys.argv[1:]])
"""
LAUNCHER = FORK_AND_EXEC + """_, status, usage = os.wait4(pid, 0)
print(time.perf_counter() - start, usage.ru_maxrss // 1024, os.waitstatus_to_exitcode(status))
"""


# An installed package has its bytecode compiled (pip does it, or Python on first import). Sandboxes and CI
# images often set PYTHONDONTWRITEBYTECODE, which would make every run compile autorig's modules again (~60 ms
# here): not what a user's run costs, so the variable is dropped for the timed processes, and a warm-up run
# writes the caches before any timing.
USER_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def run(args: list[str]) -> tuple[float, int, str]:
    """(wall seconds, peak RSS in MB, stderr) of one autorig process."""
    done = subprocess.run([sys.executable, "-c", LAUNCHER, *args], capture_output=True, text=True, env=USER_ENV)
    seconds, rss, code = done.stdout.split()
    if int(code):
        raise RuntimeError(f"autorig {' '.join(args)} failed: {done.stderr.strip()}")
    return float(seconds), int(rss), done.stderr


def stages(stderr: str) -> dict[str, float]:
    return {m.group(1).strip(): float(m.group(2)) for m in re.finditer(r"^\s+(.+?)\s+([\d.]+) s$", stderr, re.M)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--sizes", default="5000,20000,60000,200000,1000000")
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--templates", default="", help="also rig the mannequin with these templates")
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]

    for flag in ("--help", "--version"):
        run([flag])
        times = [run([flag])[0] for _ in range(args.runs)]
        print(f"autorig {flag:10s} median {statistics.median(times):.3f} s")

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = []
        meshes = build_meshes(folder, sizes, args.shared)
        meshes += [(f"{name}-{template}", size, path, ["--template", template])
                   for name, size, path, _ in list(meshes) if name == "mannequin"
                   for template in filter(None, args.templates.split(","))]
        run([str(meshes[0][2]), "-o", str(folder / "out.glb")])    # warm-up: bytecode and file caches
        timed: dict[tuple[str, int], list] = {}
        for path in dict.fromkeys(m[2] for m in meshes):
            # The templates rigging one mesh take turns, run by run, so that the other load on the machine
            # falls on each alike.
            same = [m for m in meshes if m[2] == path]
            for _ in range(args.runs if same[0][1] < 1_000_000 else max(1, args.runs // 2)):
                for name, size, _, flags in same:
                    timed.setdefault((name, size), []).append(run([str(path), "-o", str(folder / "out.glb"),
                                                                   "-v", *flags]))
        for name, size, _, _ in meshes:
            results = timed[(name, size)]
            per_stage = {}
            for _, _, err in results:
                for stage, seconds in stages(err).items():
                    per_stage.setdefault(stage, []).append(seconds)
            rows.append((name, size, statistics.median(r[0] for r in results), max(r[1] for r in results),
                         {k: statistics.median(v) for k, v in per_stage.items()}))

    stage_names = list(rows[0][4])
    print(f"\n{'mesh':10s} {'faces':>8s} {'total s':>8s} {'outside':>8s} {'peak MB':>8s}  " +
          " ".join(f"{s[:12]:>12s}" for s in stage_names))
    for name, size, total, rss, per_stage in rows:
        print(f"{name:10s} {size:8d} {total:8.2f} {total - sum(per_stage.values()):8.2f} {rss:8d}  " +
              " ".join(f"{per_stage.get(s, float('nan')):12.3f}" for s in stage_names))
    if len(sizes) < 2:
        return 0
    print("\ngrowth exponent b (time ~ faces^b), fitted per mesh over the sizes:")
    for name in dict.fromkeys(r[0] for r in rows):
        mine = [r for r in rows if r[0] == name]
        x = np.log([r[1] for r in mine])
        fits = {"total": np.polyfit(x, np.log([r[2] for r in mine]), 1)[0]}
        for s in stage_names:
            y = np.array([r[4].get(s, np.nan) for r in mine])
            if np.all(y > 1e-3):
                fits[s] = np.polyfit(x, np.log(y), 1)[0]
        print(f"  {name:10s} " + ", ".join(f"{k} {v:.2f}" for k, v in fits.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
