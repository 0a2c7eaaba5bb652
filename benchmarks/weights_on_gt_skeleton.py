#!/usr/bin/env python3
"""Bone-heat weights on the ground-truth skeleton, scored against the artists' weights.

For every rigged model in the shared data (``shared/data/rigged/*``) that has a biped or quadruped map, run
``autorig.weights.attach.bone_heat`` on the GT mesh with the GT joints and hierarchy, and score the weights with
``shared/tools/score.py`` (``weight_scores``), mapping each GT joint to its own template key so that only the
weights are judged, not the skeleton. Prints one row per model: vertices, top-1 agreement (%), mean L1 and
the time bone_heat took; then the same scores with a tip bone added after every weighted leaf joint.

Joints that the GT marks as not deforming (``"weighted": false`` in joints.json, e.g. the Fox's root joints at
the origin, outside the mesh) own no bones here, as a rigger's "deform off" bones heat nothing: the bones
leaving them are removed by making their children roots. This flag is GT metadata, so it is used only here,
never by autorig itself.

Tip bones: bone_heat gives a leaf joint no weight (it owns no bone), as autorig's templates end every chain in
an ``_end`` joint. The GT skeletons stop at the last deforming joint instead (the Fox's front legs end at the
hand joints, which carry the paws), so the second pair of columns appends to each weighted leaf a tip
joint half its incoming bone's length further on (standing in for the tail that every Blender bone has)
and scores the original columns. The tip length hardly matters: a quarter or a whole bone length give the
same top-1.

    PYTHONPATH=. python benchmarks/weights_on_gt_skeleton.py [--data DIR] [--score PATH]
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time

import numpy as np

from autorig.weights.attach import bone_heat

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.normpath(os.path.join(HERE, '..', '..', 'shared'))


def load_score_module(path):
    """Import score.py from its path (it is a tool of the shared data, not a package)."""
    spec = importlib.util.spec_from_file_location('gt_score', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def deforming_parents(gt_dir, names, parents):
    """GT parents [J] with the bones leaving non-deforming joints removed (their children become roots)."""
    with open(os.path.join(gt_dir, 'joints.json')) as fh:
        weighted = {j['name']: j.get('weighted', True) for j in json.load(fh)['joints']}
    out = np.array(parents, int).copy()
    for c, p in enumerate(parents):
        if p >= 0 and not weighted[names[p]]:
            out[c] = -1
    return out


def with_tip_bones(gt_dir, names, joints, parents, tip_fraction=0.5):
    """Joints [J', 3] and parents [J'] with a tip joint appended after every weighted leaf joint."""
    with open(os.path.join(gt_dir, 'joints.json')) as fh:
        weighted = {j['name']: j.get('weighted', True) for j in json.load(fh)['joints']}
    has_child = np.zeros(len(parents), bool)
    has_child[parents[parents >= 0]] = True
    leaves = [j for j in range(len(parents)) if not has_child[j] and parents[j] >= 0 and weighted[names[j]]]
    tips = [joints[j] + tip_fraction * (joints[j] - joints[parents[j]]) for j in leaves]
    return np.vstack([joints] + tips), np.concatenate([parents, leaves]).astype(int)


def run_model(score, gt_dir):
    """Score bone_heat on one GT rig. Returns a dict for the table, or None if the model has no map."""
    gt = score.load_gt(gt_dir)
    if gt['kind'] is None:
        return None
    names = gt['joint_names']
    parents = deforming_parents(gt_dir, names, gt['joint_parents'])
    pred_map = {n: k for k, n in gt['map'].items() if n is not None}

    def scores(W):
        return score.weight_scores(gt, W[:, :len(names)], names, gt['joint_parents'], gt['joint_pos'], pred_map,
                                   gt['V'], gt['kind'])

    t0 = time.perf_counter()
    W = bone_heat(gt['V'], gt['F'], gt['joint_pos'], parents)
    seconds = time.perf_counter() - t0
    plain = scores(W)
    tipped = scores(bone_heat(gt['V'], gt['F'], *with_tip_bones(gt_dir, names, gt['joint_pos'], parents)))
    return {'model': gt['name'], 'vertices': len(gt['V']), 'top1_pct': plain['top1_pct'],
            'l1_mean': plain['l1_mean'], 'time_s': seconds, 'top1_tips': tipped['top1_pct'],
            'l1_tips': tipped['l1_mean']}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--data', default=os.path.join(SHARED, 'data', 'rigged'), help='folder of GT rigs')
    ap.add_argument('--score', default=os.path.join(SHARED, 'tools', 'score.py'), help='path of score.py')
    a = ap.parse_args(argv)
    score = load_score_module(a.score)
    rows = []
    for name in sorted(os.listdir(a.data)):
        gt_dir = os.path.join(a.data, name)
        if os.path.isfile(os.path.join(gt_dir, 'joints.json')):
            row = run_model(score, gt_dir)
            if row is not None:
                rows.append(row)
    print(f"{'model':<16}{'vertices':>9}{'top1_pct':>10}{'l1_mean':>9}{'time_s':>8}{'top1_tips':>11}{'l1_tips':>9}")
    for r in rows:
        print(f"{r['model']:<16}{r['vertices']:>9}{r['top1_pct']:>10.1f}{r['l1_mean']:>9.3f}{r['time_s']:>8.2f}"
              f"{r['top1_tips']:>11.1f}{r['l1_tips']:>9.3f}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
