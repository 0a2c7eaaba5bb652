"""A quadruped rig scored apart from the artists' trunk convention (issue 26): limbs as points, trunk as a line.

    python benchmarks/quadruped_score.py GT_DIR RIG.glb [--shared ../shared]

Each corpus species' artist put the hips, spine, chest and neck somewhere of their own along the body
(``benchmarks/quadruped_conventions.py``), so a rig is not wrong for putting them elsewhere along the same
line. The legs, head and tail are not a convention. So:

    limbs   every joint the ground truth maps except hips, spine, chest and neck, scored as points, as
            ``shared/tools/score.py`` scores them: mean and worst (naming the worst joint);
    trunk   each of the artist's hips, spine, chest and neck scored by its distance from the rig's polyline
            hips -> spine -> chest -> neck -> head: worst (naming it).

All as % of the ground truth's height. The .glb is read and the ground truth loaded as ``score.py`` does.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TRUNK = ("hips", "spine", "chest", "neck")
TRUNK_LINE = TRUNK + ("head",)


def _score_module(shared: Path):
    sys.path.insert(0, str(shared / "tools"))
    import score
    return score


def distance_to_polyline(point: np.ndarray, line: np.ndarray) -> float:
    """Distance of ``point`` [3] from the polyline through ``line`` [N, 3] (N >= 1)."""
    if len(line) == 1:
        return float(np.linalg.norm(point - line[0]))
    starts, ends = line[:-1], line[1:]
    along = ends - starts
    lengths2 = np.maximum(np.einsum("ij,ij->i", along, along), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", point - starts, along) / lengths2, 0.0, 1.0)
    nearest = starts + t[:, None] * along
    return float(np.min(np.linalg.norm(nearest - point, axis=1)))


def convention_free(truth: dict[str, np.ndarray], rig: dict[str, np.ndarray], height: float) -> dict:
    """The convention-free score of ``rig`` against ``truth``, both {template key: position [3]}.

    Returns ``limbs`` {key: error %} (every truth key but the trunk that the rig has), ``limbs_mean``,
    ``limbs_worst`` and ``limbs_worst_joint``; ``trunk`` {key: distance % from the rig's trunk polyline} for
    the truth's hips, spine, chest and neck, ``trunk_worst`` and ``trunk_worst_joint``. The polyline runs
    through those of the rig's hips, spine, chest, neck and head it has. Missing ones are left out; a score
    with nothing to score is None.
    """
    limbs = {key: 100 * float(np.linalg.norm(np.asarray(rig[key], float) - truth[key])) / height
             for key in truth if key not in TRUNK and key in rig}
    line = np.array([rig[key] for key in TRUNK_LINE if key in rig], float).reshape(-1, 3)
    trunk = {key: 100 * distance_to_polyline(np.asarray(truth[key], float), line) / height
             for key in TRUNK if key in truth and len(line)}
    out = {"limbs": limbs, "trunk": trunk}
    for part, errors in (("limbs", limbs), ("trunk", trunk)):
        worst = max(errors, key=errors.get) if errors else None
        out[f"{part}_worst"] = errors[worst] if worst else None
        out[f"{part}_worst_joint"] = worst
    out["limbs_mean"] = float(np.mean(list(limbs.values()))) if limbs else None
    return out


def score_glb(score, gt: dict, path: Path) -> dict:
    """``convention_free`` of the rigged .glb at ``path`` against ``gt`` (``score.load_gt``), its joints read
    and named as ``score.score_glb`` reads and names them."""
    read = score.read_glb(str(path))
    keys = score.TEMPLATE_PARENT["quadruped"]
    rig = {name: read["joint_pos"][i] for i, name in enumerate(read["joint_names"]) if name in keys}
    return convention_free(score.gt_template_joints(gt), rig, gt["height"])


def line(result: dict) -> str:
    """One line: limbs mean / worst (joint), trunk worst (joint); a ground truth without them gives '-'."""
    def percent(key):
        return "   -" if result[key] is None else f"{result[key]:4.1f}"
    return (f"limbs {percent('limbs_mean')} / {percent('limbs_worst')} ({result['limbs_worst_joint']}), "
            f"trunk {percent('trunk_worst')} ({result['trunk_worst_joint']})")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gt_dir", type=Path)
    parser.add_argument("rig", type=Path)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args(argv)
    score = _score_module(args.shared)
    print(line(score_glb(score, score.load_gt(str(args.gt_dir)), args.rig)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
