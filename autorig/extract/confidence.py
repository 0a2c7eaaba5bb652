"""How far to trust an extracted skeleton (``--template auto``): ``skeleton_confidence``.

With no template to fit, the confidence is the product of three parts, each in [0, 1]:

* ``inside``: the fraction of the joints (tips included: they sit on the medial surface too) inside the mesh,
  as in ``autorig.confidence``;
* ``margin``: how clearly the shape decided which branches are limbs. Every branch tried is kept when its
  reach is at least LIMB_SHARE of the longest way out from where it hangs (``paths.grow_paths``); the closest
  call of them, the kept branch or the dropped one whose share is nearest to LIMB_SHARE (in ratio), scores 1
  when it is at least MARGIN_FULL times from it (the margin of the labelled shapes it was learned on) and less
  in proportion (in log ratio) when nearer, down to 0 on the threshold itself. Branches the noise test drops
  (ripples shorter than their own thickness, ``paths.NOISE_LENGTH``) decide nothing here;
* ``symmetry``: a mesh that is its own mirror image left to right (canonical x) should get a skeleton that is
  too. The mesh's symmetry (the share of its mirrored vertices that lie on its surface, softly, within about
  SYMMETRY_SURFACE of the height) scales the penalty for chain ends that have no mirror image among the chain
  ends (softly, within about SYMMETRY_ENDS of the height): a lopsided mesh costs nothing, a symmetric mesh
  with a lopsided skeleton costs up to everything.
"""
from __future__ import annotations

import numpy as np

from .paths import LIMB_SHARE, Candidate

# The closest calls of the labelled shapes LIMB_SHARE was learned on (benchmarks/limb_share.py: a creature's
# shortest limb, the spider's longest palp) are this many times from it: a decision at least as clear is sure.
MARGIN_FULL = 1.1
SYMMETRY_SURFACE = 0.01     # of the height: a mirrored vertex this near the surface is (softly) on it
SYMMETRY_ENDS = 0.05        # of the height: a chain end this near another's mirror image (softly) has a twin
SAMPLE = 4000               # vertices tested for the mesh's symmetry, evenly picked
# The reasons (``skeleton_reasons``): at most this many, and a part above this is no reason (as ``autorig.explain``).
MOST_REASONS = 2
LEAST_PART = 0.95


def skeleton_confidence(vertices: np.ndarray, faces: np.ndarray, joints: np.ndarray, parents: np.ndarray,
                        candidates: list[Candidate]) -> tuple[float, dict[str, float]]:
    """(confidence, {part: value}) of an extracted skeleton: vertices [V, 3], faces [F, 3] the working mesh and
    joints [J, 3] in the canonical frame (unit height, x to the left), parents [J], and the branches tried as
    limbs (``PathTree.candidates``). See the module docstring."""
    import igl

    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    winding = igl.fast_winding_number(V, F, np.ascontiguousarray(joints, dtype=np.float64))
    inside = float(np.mean(np.abs(winding) >= 0.5))
    margin, closest = decision_margin(candidates)
    symmetry, mesh_symmetry, end_symmetry = skeleton_symmetry(V, F, joints, parents)
    parts = {"inside": round(inside, 3), "margin": round(margin, 3), "closest_share": round(closest, 3),
             "symmetry": round(symmetry, 3), "mesh_symmetry": round(mesh_symmetry, 3),
             "end_symmetry": round(end_symmetry, 3)}
    return inside * margin * symmetry, parts


def decision_margin(candidates: list[Candidate]) -> tuple[float, float]:
    """(margin part in [0, 1], the share nearest to LIMB_SHARE, or 0 when no branch was decided on its share)."""
    shares = np.array([c.share for c in candidates if not c.ripple])
    if len(shares) == 0:
        return 1.0, 0.0
    gap = np.abs(np.log(np.maximum(shares, 1e-12) / LIMB_SHARE))
    k = int(np.argmin(gap))
    return float(np.clip(gap[k] / np.log(MARGIN_FULL), 0.0, 1.0)), float(shares[k])


def skeleton_symmetry(vertices: np.ndarray, faces: np.ndarray, joints: np.ndarray,
                      parents: np.ndarray) -> tuple[float, float, float]:
    """(symmetry part, the mesh's left-right symmetry, the chain ends' symmetry), each in [0, 1]; the mirror
    plane is the middle of the mesh's box across x (canonical frame, unit height)."""
    import igl
    from ..input.mesh import spread

    middle = 0.5 * (vertices[:, 0].min() + vertices[:, 0].max())
    sample = vertices[spread(vertices, SAMPLE)]
    mirrored = sample * [-1.0, 1.0, 1.0] + [2 * middle, 0.0, 0.0]
    tree = igl.AABB()
    tree.init(vertices, faces)
    squared, _, _ = tree.squared_distance(vertices, faces, np.ascontiguousarray(mirrored))
    mesh = float(np.mean(np.exp(-squared / SYMMETRY_SURFACE ** 2)))
    ends = joints[~np.isin(np.arange(len(joints)), parents)]
    twins = ends * [-1.0, 1.0, 1.0] + [2 * middle, 0.0, 0.0]
    gap = np.linalg.norm(twins[:, None] - ends[None], axis=2).min(axis=1)
    skeleton = float(np.mean(np.exp(-(gap / SYMMETRY_ENDS) ** 2)))
    return 1.0 - mesh * (1.0 - skeleton), mesh, skeleton


def skeleton_reasons(parts: dict[str, float]) -> list[str]:
    """What pulled the confidence down, in words, the lowest part first (at most MOST_REASONS; none above
    LEAST_PART): ``parts`` as ``skeleton_confidence`` returns them."""
    words = {
        "inside": f"{100 * (1 - parts['inside']):.0f} % of the joints outside the mesh",
        "margin": f"a branch reaches {parts['closest_share']:.2f} of the longest way out from where it leaves, "
                  f"near the {LIMB_SHARE:.2f} that makes a limb: limb or bump is a close call",
        "symmetry": "the mesh is its own mirror image left to right, its chains are not",
    }
    low = sorted((parts[name], name) for name in words if parts[name] < LEAST_PART)
    return [words[name] for _, name in low[:MOST_REASONS]]
