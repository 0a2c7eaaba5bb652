"""Does the quadruped confidence judge a rig or an animal's build? Corpus animals with their legs squeezed.

    python benchmarks/cross_validation.py --kinds quadruped --out DIR     # keeps each fold's template
    python benchmarks/squeezed_legs.py DIR [--factor 0.6] [--folds 4] [--shared ../shared]

Each corpus animal's mesh and artist's joints are squeezed in height below 0.8 of its lowest shoulder or hip
joint (its legs; the body above moves down with them) by ``--factor``, rigged with the template of the
cross-validation fold that did not see it (axes given) and scored apart from the trunk convention
(``quadruped_score``). A confidence that measures the rig keeps right rigs of short-legged animals at 0.5 or
more; one that measures the distance from the corpus's build does not. Printed per animal: limbs mean / worst
(% of the height) and the confidence; then how many right rigs (worst limb joint within 10 %) score 0.5 or more
and how many wrong ones (more than 20 % off) do.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import cross_validation
import quadruped_score

ROOT = Path(__file__).resolve().parents[1]


def squeezed(V: np.ndarray, joints: dict, factor: float) -> tuple[np.ndarray, dict]:
    """(vertices [V, 3], {key: [3]}) with heights below the legs' top scaled by ``factor`` about the ground."""
    low = float(V[:, 1].min())
    roots = [p[1] for k, p in joints.items() if k.endswith(("_hip", "_shoulder"))]
    top = 0.8 * ((min(roots) - low) if roots else 0.5 * float(np.ptp(V[:, 1])))
    def squeeze(y):
        u = np.asarray(y, float) - low
        return low + np.where(u < top, u * factor, top * factor + (u - top))
    out = V.copy()
    out[:, 1] = squeeze(V[:, 1])
    return out, {k: np.array([p[0], squeeze(p[1]), p[2]]) for k, p in joints.items()}


def main(argv=None) -> int:
    import autorig
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rigs", type=Path, help="a cross_validation.py --out folder")
    parser.add_argument("--factor", type=float, default=0.6)
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(args.shared / "tools"))
    import score
    items = cross_validation.corpus(args.shared / "data" / "train", "quadruped")
    fold_of = cross_validation.dealt(items, args.folds)
    rows = []
    for folder, group in items:
        template = args.rigs / f"quadruped_fold{fold_of[group]}.json"
        if not template.is_file():
            print(f"squeezed_legs: no {template}", file=sys.stderr)
            return 2
        gt = score.load_gt(str(folder))
        V, truth = squeezed(gt["V"], score.gt_template_joints(gt), args.factor)
        rig = autorig.rig((V, gt["F"]), str(template), autorig.RigOptions(up="y", front="z"))
        result = quadruped_score.convention_free(truth, dict(zip(rig.names, rig.joints)), float(np.ptp(V[:, 1])))
        rows.append((result["limbs_mean"], result["limbs_worst"], rig.info["confidence"]))
        print(f"{folder.name:18s} legs x{args.factor}: {quadruped_score.line(result)}  confidence "
              f"{rig.info['confidence']:.2f}", flush=True)
    print(summary(rows))
    return 0


def summary(rows: list[tuple[float, float, float]]) -> str:
    """One line of the (limbs mean, limbs worst, confidence) ``rows``: the means, and how many right and wrong
    rigs score 0.5 or more."""
    limbs, worst, confidence = (np.array(c) for c in zip(*rows))
    def at_least_half(chosen):
        return f"{int((confidence[chosen] >= 0.5).sum())}/{int(chosen.sum())}"
    return (f"{len(rows)} animals: limbs mean {limbs.mean():.1f} %, confidence mean {confidence.mean():.2f}; "
            f"right (worst limb <= 10 %) at >= 0.5: {at_least_half(worst <= 10)}; "
            f"wrong (> 20 %) at >= 0.5: {at_least_half(worst > 20)}")


if __name__ == "__main__":
    sys.exit(main())
