"""Where a quadruped rig's tail base and head sit against the artists', in the body's frame.

    python benchmarks/cross_validation.py --kinds quadruped --out DIR     # keeps the held-out rigs
    python benchmarks/quadruped_ends.py DIR [--shared ../shared]

For each held-out corpus rig (``DIR/NAME_after.glb``, axes given: +y up, +z front): the rig's tail base and head
minus the artist's, along the back (dz, + forward) and in height (dy, + up), and the error; the artist's tail
base's distance in front of the mesh's rearmost point and its height; the rig's head chain's end (the snout
tip the embedding found) behind the mesh's frontmost point and its height. All in % of the height. A tail base
off by the same sign on most animals is a placement's bias; a head chain ending far behind the front went into
a tusk, a horn or the neck.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def ends(score, gt: dict, glb: Path) -> dict:
    """{tail_base / head: (dz, dy, error) or None, the artist's tail base (ahead of the rear, height), the
    rig's head end (behind the front, height)} of the rig at ``glb`` against ``gt`` (``score.load_gt``)."""
    height, truth = gt["height"], score.gt_template_joints(gt)
    read = score.read_glb(str(glb))
    rig = {name: np.asarray(read["joint_pos"][i], float) for i, name in enumerate(read["joint_names"])}
    V = gt["V"]
    low, rear, front = float(V[:, 1].min()), float(V[:, 2].min()), float(V[:, 2].max())
    out = {}
    for key in ("tail_base", "head"):
        if key in truth and key in rig:
            d = 100 * (rig[key] - truth[key]) / height
            out[key] = (float(d[2]), float(d[1]), float(np.linalg.norm(d)))
        else:
            out[key] = None
    tb = truth.get("tail_base")
    out["artist_tail_base"] = None if tb is None else (100 * (tb[2] - rear) / height, 100 * (tb[1] - low) / height)
    end = rig.get("head_end")
    out["head_end"] = None if end is None else (100 * (front - end[2]) / height, 100 * (end[1] - low) / height)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rigs", type=Path, help="a cross_validation.py --out folder")
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(args.shared / "tools"))
    import score
    train = args.shared / "data" / "train"
    glbs = sorted(args.rigs.glob("*_after.glb"))
    if not glbs:
        print(f"quadruped_ends: no *_after.glb in {args.rigs}", file=sys.stderr)
        return 2
    def cell(v, n=3):
        return " ".join(["     -"] * n) if v is None else " ".join(f"{x:6.1f}" for x in v)
    print(f"{'animal':16s} | tail base dz dy err | artist's: ahead height | head dz dy err | head end: behind height")
    errors = {"tail_base": [], "head": []}
    for glb in glbs:
        name = glb.name[:-len("_after.glb")]
        if not (train / name / "joints.json").is_file():
            continue
        row = ends(score, score.load_gt(str(train / name)), glb)
        for key in errors:
            if row[key] is not None:
                errors[key].append(row[key][2])
        print(f"{name:16s} | {cell(row['tail_base'])} | {cell(row['artist_tail_base'], 2)} | {cell(row['head'])} | "
              f"{cell(row['head_end'], 2)}")
    for key, values in errors.items():
        if values:
            print(f"{key}: mean error {np.mean(values):.1f} % over {len(values)}, worst {np.max(values):.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
