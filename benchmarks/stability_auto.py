"""Stability of ``--template auto``: the same shape, written differently, must give the same skeleton.

    python benchmarks/stability_auto.py [--shared ../shared] [--voxels 96] [--creatures 8] [--seeds 3]
                                        [--only NAME,...]

Every shape (the shared octopus, spider, horse, cow and armadillo, OpenClonk's bat and squid from
``shared/data/more``, and ``--creatures`` random creatures of
``autorig.extract.shapes``, numpy seeds 0, 1, ...) is rigged as it is and as each variant:

* ``noise<s>``: every coordinate moved by uniform noise of +-1e-6 x the shape's height (numpy seed s; ``--seeds``
  of them): what re-exporting a mesh from another tool does to its floats;
* ``vertex order``: the vertices permuted (the faces renumbered to match);
* ``corners``: each triangle's corners rotated (a, b, c) -> (b, c, a);
* ``x0.01``, ``x100``: the units changed (joints compared divided by the scale).

For each variant: its chain count; whether its chains lead to the same limbs (each chain end matched to the
nearest one of the plain rig's, and that one's nearest back: a one-to-one matching of every end); whether the
joint names are the same; and how far the joints moved, in % of the height: each joint against the joint of the
same index along the matched chain (against the nearest joint of that chain when the two chains have different
joint counts). The last lines: per shape the worst variant, and overall the count of variants whose structure
changed and of those that moved any joint more than 0.5 % of the height.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SHARED = [("octopus_low", "y", "z"), ("spider", "y", "z"), ("horse", "z", "y"), ("cow", "y", "x"),
          ("armadillo", "y", "z")]
MORE = ["openclonk_bat", "openclonk_squid"]
LIMIT = 0.5          # % of the height a joint may move


def variants(vertices: np.ndarray, faces: np.ndarray, up: int, seeds: int):
    """(label, vertices, faces, scale) of each rewritten copy of the mesh."""
    height = float(np.ptp(vertices[:, up]))
    for s in range(seeds):
        noise = np.random.default_rng(s).uniform(-1e-6, 1e-6, vertices.shape) * height
        yield f"noise{s}", vertices + noise, faces, 1.0
    order = np.random.default_rng(0).permutation(len(vertices))
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order))
    yield "vertex order", vertices[order], inverse[faces], 1.0
    yield "corners", vertices, faces[:, [1, 2, 0]], 1.0
    for scale in (0.01, 100.0):
        yield f"x{scale:g}", vertices * scale, faces, scale


def chains(rig) -> dict[str, list[int]]:
    """{chain name: its joint indices, from the root out} of an extracted rig."""
    out: dict[str, list[int]] = {}
    for j, name in enumerate(rig.names[1:], start=1):
        out.setdefault(name.split("_")[0], []).append(j)
    return out


def compare(a, b, scale: float, height: float) -> tuple[bool, bool, float]:
    """(same limbs, same names, largest joint move in % of the height) of rig b (units x scale) against a."""
    ca, cb = chains(a), chains(b)
    ends_a = np.array([a.joints[j[-1]] for j in ca.values()])
    ends_b = np.array([b.joints[j[-1]] for j in cb.values()]) / scale
    gap = np.linalg.norm(ends_a[:, None] - ends_b[None], axis=2)
    forward, backward = gap.argmin(axis=1), gap.argmin(axis=0)
    same = len(ca) == len(cb) and bool(np.all(backward[forward] == np.arange(len(ca))))
    names_b = list(cb)
    moves = [float(np.linalg.norm(a.joints[0] - b.joints[0] / scale))]
    for k, joints in enumerate(ca.values()):
        other = cb[names_b[forward[k]]]
        pa, pb = a.joints[joints], b.joints[other] / scale
        if len(pa) == len(pb):
            moves.extend(np.linalg.norm(pa - pb, axis=1))
        else:
            moves.extend(np.linalg.norm(pa[:, None] - pb[None], axis=2).min(axis=1))
    return same, a.names == b.names, 100 * max(moves) / height


def shapes(shared: Path, creatures: int, only: set[str]):
    """(name, vertices, faces, up, front) of each shape to check."""
    from autorig.extract.shapes import NumpyDraw, creature, random_creature
    from autorig.input.mesh import load_mesh

    for name, up, front in SHARED:
        path = shared / "data" / "meshes" / f"{name}.obj"
        if only and name not in only:
            continue
        if not path.exists():
            print(f"# {path} not found: skipped", file=sys.stderr)
            continue
        yield name, *load_mesh(path), up, front
    for name in MORE:     # shared/data/more's animals no template fits (glTF, +y up, facing +z)
        path = shared / "data" / "more" / name / "model.glb"
        if (only and name not in only) or not path.exists():
            continue
        yield name, *load_mesh(path), "y", "z"
    for seed in range(creatures):
        if only and f"creature{seed}" not in only:
            continue
        shape = creature(random_creature(NumpyDraw(np.random.default_rng(seed))))
        yield f"creature{seed}", shape.vertices, shape.faces, "y", "z"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--voxels", type=int, default=96)
    parser.add_argument("--creatures", type=int, default=8)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--only", default="", help="comma-separated shape names (e.g. spider,creature3)")
    args = parser.parse_args(argv)

    import autorig

    only = {s for s in args.only.split(",") if s}
    print("| shape | variant | chains | same limbs | same names | largest move % height |")
    print("|---|---|---|---|---|---|")
    changed = moved = total = 0
    for name, vertices, faces, up, front in shapes(args.shared, args.creatures, only):
        options = autorig.RigOptions(up=up, front=front, voxels=args.voxels)
        axis = "xyz".index(up)
        height = float(np.ptp(vertices[:, axis]))
        plain = autorig.rig((vertices, faces), "auto", options)
        print(f"| {name} | plain | {plain.info['chains']} | - | - | - |", flush=True)
        worst = 0.0
        for label, v, f, scale in variants(vertices, faces, axis, args.seeds):
            rig = autorig.rig((v, f), "auto", options)
            same, names, move = compare(plain, rig, scale, height)
            total += 1
            changed += not same
            moved += move > LIMIT
            worst = max(worst, move)
            print(f"| {name} | {label} | {rig.info['chains']} | {'yes' if same else 'NO'} | "
                  f"{'yes' if names else 'no'} | {move:.3f} |", flush=True)
        print(f"| {name} | worst | | | | {worst:.3f} |", flush=True)
    print(f"\n{total} variants: structure changed in {changed}, a joint moved more than {LIMIT} % of the height in "
          f"{moved}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
