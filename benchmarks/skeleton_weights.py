#!/usr/bin/env python3
"""``autorig MESH --skeleton joints.json`` against Blender's "Parent with Automatic Weights", on the artists' rigs.

For every folder of ``shared/data/rigged`` with a ``joints.json``, the real command line is run on its mesh and
its own ground-truth skeleton (``autorig mesh.obj --skeleton joints.json -o out.glb``), and the .glb is scored
against the artists' weights with ``shared/tools/score.py``; then Blender's automatic weights for the same mesh and
skeleton (``benchmarks/blender_auto_weights.py``, headless; the columns are skipped when ``blender`` is absent) are
scored the same way. Neither side reads the GT's ``"weighted"`` flags.

Scoring. Models with a biped or quadruped map (CesiumMan, RiggedFigure, Fox) use score.py's ``score_glb`` /
``weight_scores`` with each GT joint mapped to its own template key, so only the weights are judged; score.py
merges the columns into its template cells (e.g. head into neck, wrists into elbows). The others (RiggedSimple,
huesitos, animation_with_skeleton) have no template map, and score.py's ``weight_scores`` only knows template
keys, so they are compared joint by joint with score.py's ``_compare`` (the function behind ``top1_pct`` and
``l1_mean``): one cell per GT joint, no merging, a stricter test. Columns: % of vertices whose dominant joint
(cell) agrees with the artists', mean L1 distance of the weight rows (0 = identical, 2 = disjoint), vertices
without any weight, and seconds (autorig: the whole process; Blender: the parenting operator alone).

    python benchmarks/skeleton_weights.py [--data DIR] [--score PATH] [--no-blender]
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.normpath(os.path.join(HERE, "..", "..", "shared"))
BLENDER_SCRIPT = os.path.join(HERE, "blender_auto_weights.py")


def load_score_module(path):
    """Import score.py from its path (it is a tool of the shared data, not a package)."""
    spec = importlib.util.spec_from_file_location("gt_score", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def scores(score, gt, W, names, vertices):
    """(top-1 %, mean L1) of weights W [V', J] with columns ``names`` (the GT's joint names) on ``vertices``."""
    index = {n: i for i, n in enumerate(names)}
    W = W[:, [index[n] for n in gt["joint_names"]]]      # the GT's column order
    if gt["kind"] is not None:
        own_keys = {n: k for k, n in gt["map"].items() if n is not None}
        s = score.weight_scores(gt, W, gt["joint_names"], gt["joint_parents"], gt["joint_pos"], own_keys,
                                vertices, gt["kind"])
        return s["top1_pct"], s["l1_mean"]
    idx, _ = score.match_vertices(gt["V"], vertices, gt["height"])
    P = W[idx]
    total = P.sum(axis=1, keepdims=True)
    P = np.divide(P, total, out=np.zeros_like(P), where=total > 0)
    s = score._compare(gt["W"], P, list(gt["joint_names"]))
    return s["top1_pct"], s["l1_mean"]


def run_autorig(score, gt, gt_dir, tmp):
    out = os.path.join(tmp, f"{gt['name']}.glb")
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "autorig.cli", os.path.join(gt_dir, "mesh.obj"), "--skeleton",
                          os.path.join(gt_dir, "joints.json"), "-o", out, "-q"], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        return {"error": run.stderr.strip()}
    rig = score.read_glb(out)
    W = rig["W"]
    top1, l1 = scores(score, gt, W, rig["joint_names"], rig["V"])
    return {"top1": top1, "l1": l1, "unweighted": int((W.sum(axis=1) <= 0).sum()), "seconds": seconds}


def run_blender(score, gt, gt_dir, tmp, blender):
    out = os.path.join(tmp, f"{gt['name']}.blender.json")
    # Debian's Blender finds its Python home through the first python3 on PATH: put the one beside blender first,
    # not a virtual environment's or pyenv's, which lack Blender's numpy.
    env = dict(os.environ, PATH=os.pathsep.join([os.path.dirname(os.path.realpath(blender)), os.environ["PATH"]]))
    run = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", BLENDER_SCRIPT,
                          "--", os.path.join(gt_dir, "mesh.obj"), os.path.join(gt_dir, "joints.json"), out],
                         capture_output=True, text=True, env=env, timeout=600)
    if run.returncode != 0 or not os.path.exists(out):
        return {"error": (run.stdout + run.stderr).strip().splitlines()[-1:]}
    with open(out) as fh:
        result = json.load(fh)
    W = np.asarray(result["weights"], float)
    top1, l1 = scores(score, gt, W, gt["joint_names"], gt["V"])
    return {"top1": top1, "l1": l1, "unweighted": result["unweighted"], "seconds": result["seconds"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.path.join(SHARED, "data", "rigged"), help="folder of GT rigs")
    ap.add_argument("--score", default=os.path.join(SHARED, "tools", "score.py"), help="path of score.py")
    ap.add_argument("--no-blender", action="store_true", help="skip Blender's columns")
    a = ap.parse_args(argv)
    score = load_score_module(a.score)
    blender = None if a.no_blender else shutil.which("blender")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in sorted(os.listdir(a.data)):
            gt_dir = os.path.join(a.data, name)
            if not os.path.isfile(os.path.join(gt_dir, "joints.json")):
                continue
            gt = score.load_gt(gt_dir)
            row = {"model": gt["name"], "vertices": len(gt["V"]), "scored": gt["kind"] or "per joint",
                   "autorig": run_autorig(score, gt, gt_dir, tmp)}
            if blender:
                row["blender"] = run_blender(score, gt, gt_dir, tmp, blender)
            rows.append(row)

    def cells(r):
        if r is None:
            return f"{'-':>7}{'-':>7}{'-':>7}{'-':>7}"
        if "error" in r:
            return f"  failed: {r['error']}"
        return f"{r['top1']:>7.1f}{r['l1']:>7.3f}{r['unweighted']:>7d}{r['seconds']:>7.2f}"

    print(f"{'':<24}{'':>9}{'':<11} {'autorig --skeleton':<28}  {'Blender automatic weights' if blender else ''}")
    print(f"{'model':<24}{'vertices':>9} {'scored':<10}{'top1%':>7}{'L1':>7}{'unw.':>7}{'s':>7}  "
          + (f"{'top1%':>7}{'L1':>7}{'unw.':>7}{'s':>7}" if blender else ""))
    for r in rows:
        print(f"{r['model']:<24}{r['vertices']:>9} {r['scored']:<10}{cells(r['autorig'])}  "
              + (cells(r.get('blender')) if blender else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
