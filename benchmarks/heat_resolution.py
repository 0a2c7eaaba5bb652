#!/usr/bin/env python3
"""How coarse a copy the bone heat may be solved on: weights of dense surfaces against the artists' own.

``autorig.weights.attach`` solves the heat of a surface with more than ``HEAT_MAX_VERTICES`` welded vertices on a
simplified copy and interpolates back. The shared rigs are small, so each is subdivided (midpoint, which keeps
the original vertices first and the shape unchanged) to at least ``--vertices`` vertices, weighted on its own
ground-truth skeleton (tip bones after weighted leaves, non-deforming joints' bones removed, as in
``weights_on_gt_skeleton.py``) with each limit in turn, and the original vertices' weights are scored with
``shared/tools/score.py``: top-1 agreement %, mean L1 and the bone_heat time per limit.

    PYTHONPATH=. python benchmarks/heat_resolution.py [--limits 8000,12000,20000,1000000] [--vertices 60000]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import trimesh

import autorig.weights.attach as attach

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from weights_on_gt_skeleton import SHARED, deforming_parents, load_score_module, with_tip_bones  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limits", default="8000,12000,20000,1000000", help="HEAT_MAX_VERTICES values to compare")
    ap.add_argument("--vertices", type=int, default=60000, help="subdivide each rig to at least this many")
    ap.add_argument("--data", default=os.path.join(SHARED, "data", "rigged"))
    ap.add_argument("--score", default=os.path.join(SHARED, "tools", "score.py"))
    a = ap.parse_args(argv)
    if not os.path.isdir(a.data):
        print(f"no shared rigs at {a.data}", file=sys.stderr)
        return 2
    score = load_score_module(a.score)
    limits = [int(x) for x in a.limits.split(",")]
    default = attach.HEAT_MAX_VERTICES
    print(f"{'model':<14}{'vertices':>9}{'dense':>9}  " + "  ".join(f"{'limit ' + str(n):>22}" for n in limits))
    for name in ("CesiumMan", "RiggedFigure", "Fox"):
        gt_dir = os.path.join(a.data, name)
        if not os.path.isdir(gt_dir):
            continue
        gt = score.load_gt(gt_dir)
        names = gt["joint_names"]
        joints, parents = with_tip_bones(gt_dir, names, gt["joint_pos"],
                                         deforming_parents(gt_dir, names, gt["joint_parents"]))
        pred_map = {n: k for k, n in gt["map"].items() if n is not None}
        V, F = gt["V"], gt["F"]
        while len(V) < a.vertices:
            V, F = trimesh.remesh.subdivide(V, F)
        cells = []
        try:
            for limit in limits:
                attach.HEAT_MAX_VERTICES = limit
                start = time.perf_counter()
                W = attach.bone_heat(V, F, joints, parents)
                seconds = time.perf_counter() - start
                s = score.weight_scores(gt, W[:len(gt["V"]), :len(names)], names, gt["joint_parents"],
                                        gt["joint_pos"], pred_map, gt["V"], gt["kind"])
                cells.append(f"{s['top1_pct']:5.1f} % {s['l1_mean']:.3f} {seconds:5.2f} s")
        finally:
            attach.HEAT_MAX_VERTICES = default
        print(f"{name:<14}{len(gt['V']):>9}{len(V):>9}  " + "  ".join(f"{c:>22}" for c in cells), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
