"""Template-free skeletons (``--template auto``): what came out on each shape, how long it took, by stage.

    python benchmarks/extract_stages.py [--shared ../shared] [--voxels 96] [--repeat 3] [--creatures 200]
                                        [--no-skeletor] [--stages]

First table, one row per shape: the shared octopus, spider, horse, cow and armadillo (the limbs a rigger would
give each; the parts in brackets may or may not get chains), then ``--creatures`` random creatures
(``autorig.extract.shapes.random_creature``, numpy seeds 0, 1, ...; 1-10 limbs, capsule or tapered, some bent,
radii down to 1.5 voxels at 96, welded or overlapping, ~5,000 faces) summarised in three rows: all of them,
the welded ones and the overlapping ones. Columns: chains against limbs; bones; the shortest bone over the
diagonal of the mesh's box; for the creatures, how many have exactly one chain per limb (``shapes.score_limbs``),
the most extra chains, how far each chain starts from where its limb leaves the body (voxels), and the most
inner joints on a straight limb; the time of a whole rig (skin weights included; wall clock and, in brackets, CPU time; the median of
``--repeat`` runs for the shared meshes, of one run each for the creatures); and skeletor's curve skeleton's leaf count on
the same mesh (``skeletor.skeletonize.by_wavefront``, default settings), a reference: ``pip install skeletor``
(benchmark only, not a dependency). The creatures that are not exactly right are listed by seed.

``--stages`` adds the second table: every shape's time per pipeline stage at each ``--voxels`` resolution
(comma-separated), the best of ``--repeat`` runs, with the voxel counts.
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# name, up, front, limbs a rigger would give it, what the chains may also include
SHARED = [
    ("octopus_low", "y", "z", 8, "8 tentacles"),
    ("spider", "y", "z", 8, "8 legs (+ 2 fangs, 2 palps)"),
    ("horse", "z", "y", 5, "4 legs, head (+ 2 ears, tail)"),
    ("cow", "y", "x", 6, "4 legs, head, tail (+ 2 horns, 2 ears, udder)"),
    ("armadillo", "y", "z", 7, "2 arms, 2 legs, tail, 2 ears (+ fingers, toes)"),
]
STAGES = ["prepare", "voxels", "distance map", "medial surface", "path tree", "control skeleton", "skin weights"]


def shared_meshes(shared: Path):
    """(name, (vertices, faces), up, front, limbs, expected) of each shared mesh that is available."""
    from autorig.input.mesh import load_mesh

    for name, up, front, limbs, expected in SHARED:
        path = shared / "data" / "meshes" / f"{name}.obj"
        if path.exists():
            yield name, load_mesh(path), up, front, limbs, expected
        else:
            print(f"# {path} not found: skipped", file=sys.stderr)


def skeletor_leaves(vertices, faces) -> str:
    """Leaf count of skeletor's wavefront curve skeleton."""
    import skeletor
    import trimesh

    skeleton = skeletor.skeletonize.by_wavefront(trimesh.Trimesh(vertices, faces, process=False), progress=False)
    return str(len(skeleton.leafs))


def timed_rig(mesh, options, repeat: int = 1):
    """(the last rig, the median wall-clock seconds of ``repeat`` whole rigs, the median CPU seconds): on a
    shared, busy machine the CPU time is the steadier measure."""
    import autorig

    wall, cpu = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        rig = autorig.rig(mesh, "auto", options)
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return rig, statistics.median(wall), statistics.median(cpu)


def shortest_bone(rig) -> float:
    bones = np.linalg.norm(rig.joints[1:] - rig.joints[rig.parents[1:]], axis=1)
    return float(bones.min() / np.linalg.norm(np.ptp(rig.vertices, axis=0)))


def creature_rows(count: int, voxels: int, with_skeletor: bool):
    """Table rows summarising ``count`` random creatures (all, welded, overlapping) and the seeds that failed."""
    import autorig
    from autorig.extract.shapes import NumpyDraw, creature, random_creature, score_limbs

    results = []
    for seed in range(count):
        spec = random_creature(NumpyDraw(np.random.default_rng(seed)))
        shape = creature(spec)
        rig, seconds, cpu = timed_rig((shape.vertices, shape.faces), autorig.RigOptions(up="y", front="z",
                                                                                         voxels=voxels))
        score = score_limbs(shape, rig.names, rig.parents, rig.joints)
        leaves = int(skeletor_leaves(shape.vertices, shape.faces)) if with_skeletor else None
        results.append((seed, spec, shape, rig, score, (seconds, cpu), leaves))
        print(f"# seed {seed}: {spec.body}, {'welded' if spec.welded else 'overlapping'}, {score.limbs} limbs, "
              f"{score.chains} chains, {score.found} found, shortest bone {score.shortest_bone:.3f}, "
              f"{seconds:.2f} s", file=sys.stderr, flush=True)
    rows = []
    for label, keep in (("all", lambda s: True), ("welded", lambda s: s.welded), ("overlapping", lambda s: not s.welded)):
        chosen = [r for r in results if keep(r[1])]
        if not chosen:
            continue
        scores = [r[4] for r in chosen]
        limbs = sum(s.limbs for s in scores)
        chains = sum(s.chains for s in scores)
        exact = sum(s.exact for s in scores)
        extra = max(s.chains - s.limbs for s in scores)
        missing = max(s.limbs - s.found for s in scores)
        starts = np.concatenate([s.start_gap for s in scores])
        inner = np.concatenate([s.straight_inner for s in scores])
        short = min(s.shortest_bone for s in scores)
        under = sum(s.shortest_bone < 0.02 for s in scores)
        wall, cpu = np.array([r[5] for r in chosen]).T
        faces = int(np.median([len(r[2].faces) for r in chosen]))
        leaves = sum(r[6] for r in chosen) if with_skeletor else None
        rows.append([f"{len(chosen)} creatures, {label}", f"{faces}", f"{limbs}", f"{chains}",
                     f"{exact}/{len(chosen)} ({100 * exact / len(chosen):.0f}%) exact; most extra {extra}, "
                     f"most missing {missing}", f"{int(np.median([len(r[3].names) - 1 for r in chosen]))} (median)",
                     f"{short:.3f} ({under} under 0.02)",
                     f"median {np.median(starts):.1f}, 95% {np.percentile(starts, 95):.1f}" if len(starts) else "-",
                     f"{int(inner.max())}" if len(inner) else "-",
                     f"median {np.median(wall):.2f} ({np.median(cpu):.2f}), max {wall.max():.2f} ({cpu.max():.2f})",
                     f"{leaves} for {limbs} limbs" if leaves is not None else "-"])
    failed = [(r[0], r[4]) for r in results if not r[4].exact]
    return rows, failed


def stage_table(shared: Path, resolutions: list[int], repeat: int) -> None:
    """Per-stage times (best of ``repeat``) and voxel counts of the shared meshes and the fixture shapes."""
    import autorig
    from autorig.extract.shapes import star, tree

    def shapes():
        for name, mesh, up, front, _, _ in shared_meshes(shared):
            yield name, mesh, up, front
        for arms in (5, 8):
            s = star(arms=arms)
            yield f"star({arms})", (s.vertices, s.faces), "y", "z"
        for levels in (2, 3):
            s = tree(levels=levels)
            yield f"tree({levels})", (s.vertices, s.faces), "y", "z"

    short = {"medial surface": "medial", "control skeleton": "control", "skin weights": "weights",
             "distance map": "distance"}
    header = ["mesh", "verts", "voxels"] + [short.get(s, s) for s in STAGES] + ["total s", "inside", "medial",
                                                                                  "chains", "joints"]
    print("\n| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, mesh, up, front in shapes():
        for voxels in resolutions:
            best: dict[str, float] = {}
            for _ in range(repeat):
                rig = autorig.rig(mesh, "auto", autorig.RigOptions(up=up, front=front, voxels=voxels))
                best = {k: min(v, best.get(k, v)) for k, v in rig.timings.items()}
            row = [name, str(len(mesh[0])), str(voxels)] + [f"{best.get(s, 0.0):.3f}" for s in STAGES]
            row += [f"{sum(best.values()):.2f}", str(rig.info["inside_voxels"]), str(rig.info["medial_voxels"]),
                    str(rig.info["chains"]), str(len(rig.names))]
            print("| " + " | ".join(row) + " |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--voxels", default="96", help="comma-separated resolutions; the first for the shapes")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--creatures", type=int, default=200)
    parser.add_argument("--no-skeletor", action="store_true", help="leave out skeletor's leaf counts")
    parser.add_argument("--stages", action="store_true", help="add the per-stage times")
    args = parser.parse_args()

    import autorig

    resolutions = [int(v) for v in args.voxels.split(",")]
    voxels = resolutions[0]
    with_skeletor = not args.no_skeletor and importlib.util.find_spec("skeletor") is not None
    header = ["shape", "faces", "limbs", "chains", "one chain per limb", "bones", "shortest bone / diagonal",
              "chain start from limb base (voxels)", "straight limb: most inner joints", "rig s, wall (cpu)",
              "skeletor leaves"]
    print(f"voxels {voxels}")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, mesh, up, front, limbs, expected in shared_meshes(args.shared):
        rig, seconds, cpu = timed_rig(mesh, autorig.RigOptions(up=up, front=front, voxels=voxels), args.repeat)
        row = [name, str(len(mesh[1])), expected, str(rig.info["chains"]), "-", str(len(rig.names) - 1),
               f"{shortest_bone(rig):.3f}", "-", "-", f"{seconds:.2f} ({cpu:.2f})",
               skeletor_leaves(*mesh) if with_skeletor else "-"]
        print("| " + " | ".join(row) + " |", flush=True)
    if args.creatures:
        rows, failed = creature_rows(args.creatures, voxels, with_skeletor)
        for row in rows:
            print("| " + " | ".join(row) + " |", flush=True)
        for seed, score in failed:
            print(f"seed {seed}: {score.limbs} limbs, {score.chains} chains, {score.found} found")
    if args.stages:
        stage_table(args.shared, resolutions, args.repeat)


if __name__ == "__main__":
    main()
