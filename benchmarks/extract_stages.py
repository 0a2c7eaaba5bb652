"""Template-free skeletons (``--template auto``): the time of each stage per mesh, and what came out.

    python benchmarks/extract_stages.py [--shared ../shared] [--voxels 64,96,128] [--repeat 3]

For the shared meshes with many limbs or no fitting template (octopus, spider, horse, cow, armadillo) and the
procedural shapes of ``autorig.extract.shapes`` (stars, trees), rigs each with ``autorig.rig(mesh, "auto")`` at
every voxel resolution asked for and prints one table row per (mesh, resolution): the stage times the pipeline
records (the best of ``--repeat`` runs, so that one-off start-up costs do not count), the total, and the
skeleton's size (inside voxels, medial voxels, chains, joints). Expected chains: one per limb, given where known.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# name, up, front, limbs the chains should include (legs, tentacles) or None
SHARED = [
    ("octopus_low", "y", "z", "8 tentacles"),
    ("spider", "y", "z", "8 legs (+ fangs, palps)"),
    ("horse", "z", "y", "4 legs, head (+ ears, tail)"),
    ("cow", "y", "x", "4 legs, head, tail (+ horns, ears, udder)"),
    ("armadillo", "y", "z", "2 arms, 2 legs, tail, 2 ears (+ fingers, toes)"),
]
STAGES = ["prepare", "voxels", "distance map", "medial surface", "path tree", "control skeleton", "skin weights"]


def meshes(shared: Path):
    """(name, (vertices, faces), up, front, expected) of every benchmark mesh that is available."""
    from autorig.extract.shapes import star, tree
    from autorig.mesh import load_mesh

    for name, up, front, expected in SHARED:
        path = shared / "data" / "meshes" / f"{name}.obj"
        if path.exists():
            yield name, load_mesh(path), up, front, expected
        else:
            print(f"# {path} not found: skipped", file=sys.stderr)
    for arms in (5, 8):
        shape = star(arms=arms)
        yield f"star({arms})", (shape.vertices, shape.faces), "y", "z", f"{arms} arms"
    for levels in (2, 3):
        shape = tree(levels=levels)
        yield f"tree({levels})", (shape.vertices, shape.faces), "y", "z", f"{2 ** levels} twigs + trunk foot"


def best_timings(mesh, options, repeat: int):
    """The rig of the last run and {stage: the least seconds over ``repeat`` runs}."""
    import autorig

    best: dict[str, float] = {}
    for _ in range(repeat):
        rig = autorig.rig(mesh, "auto", options)
        best = {k: min(v, best.get(k, v)) for k, v in rig.timings.items()}
    return rig, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--voxels", default="64,96", help="comma-separated resolutions (default 64,96)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    import autorig

    resolutions = [int(v) for v in args.voxels.split(",")]
    short = {"medial surface": "medial", "control skeleton": "control", "skin weights": "weights",
             "distance map": "distance"}
    header = ["mesh", "verts", "voxels"] + [short.get(s, s) for s in STAGES] + ["total s", "inside", "medial",
                                                                                  "chains", "joints", "expected"]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, mesh, up, front, expected in meshes(args.shared):
        for voxels in resolutions:
            options = autorig.RigOptions(up=up, front=front, voxels=voxels)
            rig, t = best_timings(mesh, options, args.repeat)
            row = [name, str(len(mesh[0])), str(voxels)] + [f"{t.get(s, 0.0):.3f}" for s in STAGES]
            row += [f"{sum(t.values()):.2f}", str(rig.info["inside_voxels"]), str(rig.info["medial_voxels"]),
                    str(rig.info["chains"]), str(len(rig.names)), expected]
            print("| " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
