#!/usr/bin/env python3
"""How skin weights deform on the artist's own skeleton: the artist's weights against autorig's and Blender's.

    python benchmarks/deformation_skeletons.py [--shared ../shared] [--corpus ../corpus] [--per-source N]
                                               [--frames K] [--only NAME ...] [--no-blender]

The companion of ``benchmarks/deformation.py`` (same characters, same poses: single-joint bends of every limb
and ``K`` frames of each shared BVH clip, retargeted onto the artist's rig) with the skeleton held fixed, so
that only the weights are judged: each ground-truth character is posed three times on its artist's skeleton,
with the artist's weights, with autorig's (``autorig.pipeline.skin``, what ``autorig MESH --skeleton
joints.json`` computes) and with Blender's automatic weights ("Parent with Automatic Weights",
``benchmarks/blender_auto_weights.py`` run headless; skipped with ``--no-blender`` or without ``blender``).
The posed vertices of the two automatic weightings are compared with the artist's: mean, 95th percentile and
worst over vertices and poses, % of the height, per character and per source (mean of the means, mean of the
95th percentiles, the worst). Neither side reads the artist's ``"weighted"`` flags.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from deformation import _triple, artist_rig, characters, load_score, poses  # noqa: E402
from skeleton_weights import BLENDER_SCRIPT  # noqa: E402

from autorig.pipeline import skin  # noqa: E402
from autorig.result import Rig  # noqa: E402


def blender_weights(gt_dir: Path, blender: str, tmp: str) -> np.ndarray:
    """[V, J] Blender's automatic weights of the character's mesh for its joints.json (in that order)."""
    out = os.path.join(tmp, f"{gt_dir.name}.blender.json")
    # Debian's Blender finds its Python home through the first python3 on PATH (see skeleton_weights.py)
    env = dict(os.environ, PATH=os.pathsep.join([os.path.dirname(os.path.realpath(blender)), os.environ["PATH"]]))
    run = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", BLENDER_SCRIPT,
                          "--", str(gt_dir / "mesh.obj"), str(gt_dir / "joints.json"), out],
                         capture_output=True, text=True, env=env, timeout=1800)
    if run.returncode != 0 or not os.path.exists(out):
        raise RuntimeError(" ".join((run.stdout + run.stderr).strip().splitlines()[-1:]) or "blender failed")
    with open(out) as fh:
        return np.asarray(json.load(fh)["weights"], float)


def in_gt_order(gt, names: list[str], W: np.ndarray) -> np.ndarray:
    """W [V, J] with columns ``names`` reordered to the ground truth's joints (a joint W lacks: zeros)."""
    index = {n: i for i, n in enumerate(names)}
    out = np.zeros((len(W), len(gt["joint_names"])))
    for k, n in enumerate(gt["joint_names"]):
        if n in index:
            out[:, k] = W[:, index[n]]
    return out


def score_character(score, source, gt_dir: Path, motion_dir: Path, frames: int, blender: str | None, tmp: str):
    gt = score.load_gt(str(gt_dir))
    if gt["kind"] is None or gt["up"] is None or gt["front"] is None:
        return None
    artist = artist_rig(gt)
    weightings, seconds = {}, {}
    start = time.perf_counter()
    ours = skin((gt["V"], gt["F"]), str(gt_dir / "joints.json"))
    seconds["autorig"] = time.perf_counter() - start
    weightings["autorig"] = in_gt_order(gt, list(ours.names), np.asarray(ours.weights, float))
    if blender:
        start = time.perf_counter()
        weightings["blender"] = blender_weights(gt_dir, blender, tmp)
        seconds["blender"] = time.perf_counter() - start
    rigs = [artist] + [artist_rig(dict(gt, W=W)) for W in weightings.values()]
    H = gt["height"]
    errors = {k: [] for k in weightings}
    for _, posed in poses(gt, gt["kind"], rigs, motion_dir, frames):
        for k, p in zip(weightings, posed[1:]):
            errors[k].append(np.linalg.norm(p - posed[0], axis=1) / H)
    stats = {}
    for k, errs in errors.items():
        err = np.concatenate(errs) if errs else np.full(1, np.nan)
        stats[k] = (100 * err.mean(), 100 * np.percentile(err, 95), 100 * err.max())
    return {"source": source, "name": gt_dir.name, "poses": len(errors["autorig"]), "stats": stats,
            "seconds": seconds}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    ap.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    ap.add_argument("--per-source", type=int, default=3, help="characters per source (default 3)")
    ap.add_argument("--frames", type=int, default=6, help="frames of each clip (default 6)")
    ap.add_argument("--only", nargs="*", default=[], help="only these characters (folder names)")
    ap.add_argument("--no-blender", action="store_true", help="skip Blender's automatic weights")
    a = ap.parse_args(argv)
    score = load_score(a.shared)
    blender = None if a.no_blender else shutil.which("blender")
    kinds = ["autorig"] + (["blender"] if blender else [])
    print("posed vertices on the artist's skeleton, the artist's weights against autorig's"
          + (" and Blender's" if blender else "") + ", % of the height: mean/p95/worst over bends and clip frames")
    print(f"{'source':<11}{'character':<25}{'poses':>6}" + "".join(f"{k + ' mean/p95/worst':>26}" for k in kinds))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for source, d in characters(a.shared, a.corpus, a.per_source, a.only):
            try:
                row = score_character(score, source, d, a.shared / "data" / "motion", a.frames, blender, tmp)
            except Exception as e:        # one character that fails is reported, the rest go on
                print(f"{source:<11}{d.name[:24]:<25} failed: {type(e).__name__}: {e}", flush=True)
                continue
            if row is None:
                continue
            rows.append(row)
            print(f"{source:<11}{row['name'][:24]:<25}{row['poses']:>6}"
                  + "".join(f"{_triple(row['stats'][k]):>26}" for k in kinds), flush=True)
    print("\nper source: mean of the means / mean of the 95th percentiles / worst (% of the height)")
    for source in dict.fromkeys(r["source"] for r in rows):
        sel = [r for r in rows if r["source"] == source]
        cells = []
        for k in kinds:
            s = [r["stats"][k] for r in sel]
            cells.append(f"{k} " + _triple((np.mean([x[0] for x in s]), np.mean([x[1] for x in s]),
                                             np.max([x[2] for x in s]))))
        print(f"  {source:<10}{len(sel):>3} chars  " + "   ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
