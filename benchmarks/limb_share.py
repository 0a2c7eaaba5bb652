"""Where ``--template auto``'s limb test (``autorig.extract.paths.LIMB_SHARE``) sits among labelled branches.

    python benchmarks/limb_share.py [--shared ../shared] [--voxels 96,64] [--creatures 200]

Every branch the path tree tries (``PathTree.candidates``, the ripples the noise test drops left out) has a
share: its reach beyond where it leaves the body over the longest way out from where it hangs. A branch is a
limb when its share is at least LIMB_SHARE. Labelled here:

* the random creatures of ``autorig.extract.shapes`` (numpy seeds 0, 1, ...: the benchmark's and the tests'):
  a branch is a limb when its tip and one of the creature's limb tips are each other's nearest and within
  ``shapes.TIP_TOLERANCE`` of the longest side; everything else (the blobs' bumps, the rims of flat bodies) is
  not;
* the shared spider: its legs are the separate parts that reach the ground (within 10 % of the height), and a
  branch is a leg when its tip and a leg's lowest point are each other's nearest; the rest (fangs, palps, the
  head) are not;
* the shared octopus: every branch is an arm.

Printed per source and resolution: the smallest share of a limb and the largest of a non-limb, and their
margins from LIMB_SHARE (ratios); then over all of them, the two closest calls. The first branch (the farthest
extreme point) is always kept and has no share.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def branches(vertices, faces, voxels: int, up: str = "y", front: str = "z"):
    """(tips [K, 3] in the mesh's frame, shares [K]) of the branches tried that were not dropped as ripples."""
    from autorig.extract import connected_medial, distance_map, inside_graph, medial_surface, path_tree, voxelize
    from autorig.input.mesh import prepare

    prepared = prepare(vertices, faces, up, front, name="mesh", checked=True)
    grid = voxelize(prepared.work_vertices, prepared.work_faces, voxels)
    depth = distance_map(grid, prepared.work_vertices, prepared.work_faces)
    graph = connected_medial(inside_graph(depth), medial_surface(depth))
    tree = path_tree(graph)
    tried = [c for c in tree.candidates if not c.ripple]
    tips = prepared.from_canonical(grid.centres(graph.voxels[[c.tip for c in tried]])).reshape(-1, 3)
    return tips, np.array([c.share for c in tried])


def mutual(points: np.ndarray, targets: np.ndarray, tolerance: float) -> np.ndarray:
    """[K] bool: points whose nearest target has them as its nearest point, within tolerance."""
    out = np.zeros(len(points), dtype=bool)
    if len(points) == 0 or len(targets) == 0:
        return out
    gap = np.linalg.norm(points[:, None] - targets[None], axis=2)
    for t, k in enumerate(gap.argmin(axis=0)):
        if gap[k].argmin() == t and gap[k, t] < tolerance:
            out[k] = True
    return out


def spider_legs(vertices, faces) -> np.ndarray:
    """The lowest point [8, 3] of each separate part of the spider that reaches the ground."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    parts = [np.unique(faces[c]) for c in trimesh.graph.connected_components(mesh.face_adjacency, min_len=1)]
    ground = vertices[:, 1].min() + 0.1 * np.ptp(vertices[:, 1])
    legs = [p for p in parts if vertices[p, 1].min() < ground]
    return np.array([vertices[p[np.argmin(vertices[p, 1])]] for p in legs])


def labelled(shared: Path, voxels: int, creatures: int):
    """(source, shares of limbs [*], shares of non-limbs [*]) of each labelled source at ``voxels``."""
    from autorig.extract.shapes import TIP_TOLERANCE, NumpyDraw, creature, random_creature
    from autorig.input.mesh import load_mesh

    path = shared / "data" / "meshes" / "spider.obj"
    if path.exists():
        vertices, faces = load_mesh(path)
        tips, shares = branches(vertices, faces, voxels)
        legs = mutual(tips, spider_legs(vertices, faces), 0.3 * np.ptp(vertices[:, 1]))
        yield "spider", shares[legs], shares[~legs]
    path = shared / "data" / "meshes" / "octopus_low.obj"
    if path.exists():
        _, shares = branches(*load_mesh(path), voxels)
        yield "octopus", shares, np.array([])
    limbs, bumps = [], []
    for seed in range(creatures):
        shape = creature(random_creature(NumpyDraw(np.random.default_rng(seed))))
        tips, shares = branches(shape.vertices, shape.faces, voxels)
        real = mutual(tips, shape.tips, TIP_TOLERANCE * np.ptp(shape.vertices, axis=0).max())
        limbs.append(shares[real])
        bumps.append(shares[~real])
    if creatures:
        yield f"{creatures} creatures", np.concatenate(limbs), np.concatenate(bumps)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--voxels", default="96,64", help="comma-separated resolutions")
    parser.add_argument("--creatures", type=int, default=200)
    args = parser.parse_args(argv)

    from autorig.extract.paths import LIMB_SHARE

    print(f"LIMB_SHARE {LIMB_SHARE}")
    print("| source | voxels | limbs | smallest limb share (margin) | non-limbs | largest non-limb share (margin) |")
    print("|---|---|---|---|---|---|")
    low_limb, high_bump = (np.inf, ""), (-np.inf, "")
    for voxels in (int(v) for v in args.voxels.split(",")):
        creatures = args.creatures if voxels == 96 else 0       # the creatures' limbs are sized for 96 voxels
        for source, limbs, bumps in labelled(args.shared, voxels, creatures):
            a = f"{limbs.min():.3f} (x{limbs.min() / LIMB_SHARE:.2f})" if len(limbs) else "-"
            b = f"{bumps.max():.3f} (x{LIMB_SHARE / bumps.max():.2f})" if len(bumps) else "-"
            print(f"| {source} | {voxels} | {len(limbs)} | {a} | {len(bumps)} | {b} |", flush=True)
            if len(limbs) and limbs.min() < low_limb[0]:
                low_limb = (float(limbs.min()), f"{source} at {voxels}")
            if len(bumps) and bumps.max() > high_bump[0]:
                high_bump = (float(bumps.max()), f"{source} at {voxels}")
    print(f"\nclosest limb: {low_limb[0]:.3f} ({low_limb[1]}); largest non-limb: {high_bump[0]:.3f} ({high_bump[1]}); "
          f"wrong calls: {int(low_limb[0] < LIMB_SHARE) + int(high_bump[0] >= LIMB_SHARE)} kinds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
