"""Rig accuracy against ground truth: the shared real characters and the project's own mannequins.

    python benchmarks/accuracy.py [--shared ../shared] [--out DIR] [--cv [--folds 4] [--corpus ../corpus]]
                                  [--humanoid]

For each real character in ``shared/data/rigged`` that has a template map, the rig is made as a user makes it
(``autorig MESH --template T [--front AXIS] -o OUT.glb``) and the .glb is scored by ``shared/tools/score.py``,
so the numbers mean what the shared scorer means: joint error as a fraction of the height (mean and worst
over the template joints the ground truth maps) and skin-weight agreement on the dominant joint. The
mannequins (``autorig.samples``) know their exact skeleton, so they are scored on joints only. A quadruped is
also scored apart from its artist's trunk convention (``benchmarks/quadruped_score.py``: limbs as points, the
artist's hips, spine, chest and neck by their distance from the rig's trunk line), on a line of its own.

With ``--cv``, also the cross-validation, each kind learned as ``templates/retrain.sh`` learns it: the biped
leave-one-source-out (``benchmarks/sources.py``: every source of its examples held out whole, 0 A.D. by group,
rigged in the engines' convention and in its own), the quadruped on the training corpus
(``benchmarks/cross_validation.py``: learned from the other folds of whole groups and tested on the held-out
ones, before (hand-set) against after); the two kinds run side by side in two processes.

With ``--humanoid``, also the humanoid template cross-validated by group on the corpus, in T-pose, A-pose and
with the arms down (``benchmarks/humanoid.py``: the corpus characters re-posed through their artists' weights).

Also checked per model: every non-tip joint inside the mesh (generalized winding number >= 0.5) and left
and right not swapped (each left_ joint nearer the true left joint than the true right one).
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# name, template, extra CLI flags, Pinocchio's (mean %, worst %, weight top-1 %) on the same model
SHARED = [
    ("CesiumMan", "biped", ["--front", "x"], (5.3, 9.7, 85.0)),
    ("RiggedFigure", "biped", [], (5.9, 12.9, 52.0)),
    ("Fox", "quadruped", [], (13.3, 32.2, 69.0)),
]
MANNEQUINS = [("t", "adult"), ("a", "adult"), ("down", "adult"), ("t", "child"), ("a", "heavy"), ("down", "tall")]


def run_cli(mesh: Path, template: str, flags: list[str], out: Path) -> tuple[float, float]:
    """(seconds, confidence) of ``autorig MESH`` as a user runs it (the confidence from its summary line)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "--template", template, *flags,
                           "-o", str(out)], check=True, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    return seconds, float(re.search(r"confidence ([0-9.]+)", done.stdout).group(1))


def side_checks(names, joints, truth, vertices, faces):
    """(all non-tip joints inside the mesh, left/right consistent) for predicted ``joints`` [J, 3]."""
    import igl
    solid = [i for i, n in enumerate(names) if not n.endswith("_end")]
    winding = igl.fast_winding_number(np.asarray(vertices, float), np.asarray(faces, np.int64),
                                      np.asarray(joints, float)[solid])
    inside = bool(np.all(winding >= 0.5))
    index = {n: i for i, n in enumerate(names)}
    swapped = []
    for name in names:
        if "left_" not in name:
            continue
        other = name.replace("left_", "right_")
        if name in truth and other in truth and name in index:
            p = joints[index[name]]
            if np.linalg.norm(p - truth[name]) > np.linalg.norm(p - truth[other]):
                swapped.append(name)
    return inside, swapped


def shared_rows(shared: Path, out_dir: Path):
    sys.path.insert(0, str(shared / "tools"))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import score
    import quadruped_score
    from autorig.exchange.gltf import read_glb
    rows = []
    for name, template, flags, reference in SHARED:
        gt_dir = shared / "data" / "rigged" / name
        if not gt_dir.is_dir():
            continue
        out = out_dir / f"{name}.glb"
        seconds, confidence = run_cli(gt_dir / "mesh.obj", template, flags, out)
        result = json.loads(subprocess.run([sys.executable, str(shared / "tools" / "score.py"), str(gt_dir),
                                            str(out), "--kind", template], check=True, capture_output=True,
                                           text=True).stdout)
        gt = score.load_gt(str(gt_dir))
        truth = {k: gt["joint_pos"][gt["joint_names"].index(v)] for k, v in gt["map"].items() if v}
        rig = read_glb(out)
        inside, swapped = side_checks(rig.names, rig.joints, truth, gt["V"], gt["F"])
        rows.append({"model": name, "template": template, "mean": 100 * result["joints"]["mean"],
                     "max": 100 * result["joints"]["max"], "top1": result["weights"]["top1_pct"],
                     "l1": result["weights"]["l1_mean"], "inside": inside, "swapped": swapped,
                     "seconds": seconds, "confidence": confidence, "reference": reference,
                     # the trunk joints are each species' convention: also scored apart from it (issue 26)
                     "convention_free": (quadruped_score.line(quadruped_score.score_glb(score, gt, out))
                                         if template == "quadruped" else None)})
    return rows


def mannequin_rows(out_dir: Path):
    from autorig.exchange.gltf import read_glb
    from autorig.samples import mannequin
    import trimesh
    rows = []
    for pose, proportions in MANNEQUINS:
        sample = mannequin(pose=pose, proportions=proportions)
        mesh_path = out_dir / f"mannequin_{pose}_{proportions}.obj"
        trimesh.Trimesh(sample.vertices, sample.faces, process=False).export(mesh_path)
        out = out_dir / f"mannequin_{pose}_{proportions}.glb"
        seconds, confidence = run_cli(mesh_path, "biped", [], out)
        rig = read_glb(out)
        height = float(np.ptp(sample.vertices[:, 1]))
        keys = [n for n in rig.names if not n.endswith("_end") and n in sample.joints]
        errors = np.array([np.linalg.norm(rig.joints[rig.names.index(k)] - sample.joints[k]) / height
                           for k in keys])
        inside, swapped = side_checks(rig.names, rig.joints, sample.joints, sample.vertices, sample.faces)
        rows.append({"model": f"mannequin {pose}/{proportions}", "template": "biped", "mean": 100 * errors.mean(),
                     "max": 100 * errors.max(), "top1": None, "l1": None, "inside": inside, "swapped": swapped,
                     "seconds": seconds, "confidence": confidence, "reference": None})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--out", type=Path, help="keep the rigs here (default: a temporary folder)")
    parser.add_argument("--cv", action="store_true", help="also cross-validate on shared/data/train")
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus",
                        help="with --cv: the corpora data/corpus/*.py build (default ../corpus)")
    parser.add_argument("--humanoid", action="store_true",
                        help="also the humanoid, cross-validated in three rest poses (benchmarks/humanoid.py)")
    args = parser.parse_args(argv)
    cv = _start_cross_validation(args.shared, args.folds, args.corpus) if args.cv else None
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        rows = (shared_rows(args.shared, out_dir) if (args.shared / "data").is_dir() else []) + mannequin_rows(out_dir)
    print(f"{'model':24s} {'template':9s} {'joint err mean/max %':>21s} {'weights top1 %':>15s} {'L1':>6s} "
          f"{'inside':>6s} {'L/R ok':>6s} {'conf':>5s} {'time s':>7s}   Pinocchio mean/max/top1")
    for r in rows:
        top1 = f"{r['top1']:.1f}" if r["top1"] is not None else "-"
        l1 = f"{r['l1']:.3f}" if r["l1"] is not None else "-"
        ref = "{:.1f} / {:.1f} / {:.0f}".format(*r["reference"]) if r["reference"] else ""
        print(f"{r['model']:24s} {r['template']:9s} {r['mean']:10.1f} / {r['max']:5.1f}    {top1:>15s} {l1:>6s} "
              f"{str(r['inside']):>6s} {str(not r['swapped']):>6s} {r['confidence']:5.2f} {r['seconds']:7.2f}   {ref}")
    for r in rows:
        if r.get("convention_free"):
            print(f"{r['model']} apart from the trunk convention (% of height): {r['convention_free']}")
    if cv is not None:
        for future in cv:
            print(future.result())
    if args.humanoid:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        import humanoid
        with tempfile.TemporaryDirectory() as tmp:
            print(humanoid.summary(humanoid.evaluate(args.shared, args.corpus, args.folds, Path(tmp),
                                                     lambda _line: None)))
    return 0


KINDS = ("biped", "quadruped")


def _start_cross_validation(shared: Path, folds: int, corpus: Path):
    """Futures of the cross-validation summaries of both kinds, each computed in a process of its own."""
    from concurrent.futures import ProcessPoolExecutor
    pool = ProcessPoolExecutor(max_workers=len(KINDS))
    futures = [pool.submit(_cross_validation, kind, shared, folds, corpus) for kind in KINDS]
    pool.shutdown(wait=False)
    return futures


def _cross_validation(kind: str, shared: Path, folds: int, corpus: Path) -> str:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import cross_validation
    if kind == "biped":
        import sources
        with tempfile.TemporaryDirectory() as tmp:
            rows = sources.evaluate(shared, corpus, folds, Path(tmp), lambda _line: None)
        return "\n".join([sources.summary(rows)] + [sources.line(r) for r in rows])
    with tempfile.TemporaryDirectory() as tmp:
        rows = cross_validation.evaluate(kind, shared / "data" / "train", folds, Path(tmp), shared,
                                         lambda _line: None, cross_validation.shipped_parts(kind))
    return "\n".join([cross_validation.summary(kind, rows)] + [cross_validation._line(r) for r in rows])


if __name__ == "__main__":
    sys.exit(main())
