"""How much to trust a rig: one number in [0, 1] from what the stages already know, with its parts.

=========  =========================================================================================
part       what lowers it
=========  =========================================================================================
fit        a high embedding penalty per reduced bone (bones far from the template's proportions and
           directions): 1 / (1 + (penalty per bone / 0.5)^4)
limbs      template limb ends that had to be put on spheres that do not stand out as limb ends (a
           limbless torso has no hands or feet to find): the fraction placed on real extremities
extra      limbs of the shape that the template left empty (an octopus rigged as a biped): ends that
           stand out at least 60% as much as the rigged limbs (median), counted against the template's
           own number of limb ends: 1 / (1 + unused / limb ends)
inside     joints outside the mesh: the fraction of non-tip joints inside
symmetry   mirrored joints that are not mirror images: 1 / (1 + (mean mismatch / 10% of height)^2)
search     0.8 when the A* search ran out of budget and took its greedy embedding
=========  =========================================================================================

The confidence is their product. ``STRICT_THRESHOLD`` is where ``--strict`` stops a pipeline: every good
rig of the shared test characters and the mannequins scores above it, a cylinder or a limbless torso rigged
as a biped below.
"""
from __future__ import annotations

import numpy as np

from .distance import DistanceField
from .embed.penalties import PROMINENCE, prominences
from .embed.search import Embedding
from .graph import SphereGraph
from .template import Template

STRICT_THRESHOLD = 0.5
UNRIGGED_REACH = 0.25    # an end nearer than this (height units) to the rigged skeleton belongs to a rigged limb
LIMB_LIKE = 0.6          # an unused end counts as a limb when it stands out this much of the rigged ones
FIT_SCALE = 0.5          # embedding penalty per reduced bone at which the fit part is 1/2


def rig_confidence(field: DistanceField, graph: SphereGraph, embedding: Embedding, template: Template,
                   joints: np.ndarray) -> tuple[float, dict[str, float]]:
    """(confidence, {part: value}) for ``joints`` [J, 3] (canonical frame) embedded as ``embedding``."""
    reduced = template.reduced()
    leaves = [k for k in range(len(reduced.joints)) if k not in set(reduced.parents.tolist())]
    per_bone = embedding.cost / max(len(reduced.joints) - 1, 1)
    prominence = prominences(graph)
    ends = set(np.flatnonzero(prominence >= PROMINENCE).tolist())
    placed = [int(embedding.spheres[k]) for k in leaves]
    used_spheres = {s for path in embedding.paths for s in path}
    # Only ends that stand out about as much as the template's own limbs count as limbs left unrigged (an
    # octopus's other tentacles), not ears or the bumps of a low-poly model.
    limb_like = LIMB_LIKE * float(np.median(np.minimum(prominence[placed], 1.0)))
    unrigged = sorted(s for s in ends - used_spheres if prominence[s] >= limb_like)
    unused_ends = _count_distinct_ends(graph, unrigged, used_spheres)

    solid = [j for j in range(len(template.names)) if not template.is_tip(j)]
    inside = float(np.mean(field.depth(joints[solid]) > 0))
    if template.symmetry:
        left = np.array([i for i, _ in template.symmetry])
        right = np.array([j for _, j in template.symmetry])
        mismatch = float(np.mean(np.linalg.norm(joints[left] * [-1, 1, 1] - joints[right], axis=1)))
    else:
        mismatch = 0.0
    parts = {
        "fit": 1.0 / (1.0 + (per_bone / FIT_SCALE) ** 4),
        "limbs": float(np.mean([s in ends for s in placed])),
        "extra": 1.0 / (1.0 + unused_ends / len(leaves)),
        "inside": inside,
        "symmetry": 1.0 / (1.0 + (mismatch / 0.1) ** 2),
        "search": 1.0 if embedding.optimal else 0.8,
    }
    return float(np.prod(list(parts.values()))), {k: round(float(v), 3) for k, v in parts.items()}


def _count_distinct_ends(graph: SphereGraph, candidates: list[int], used: set[int]) -> int:
    """How many limbs the ``candidates`` (extremity spheres off every embedded path) stand for: an extremity
    within UNRIGGED_REACH of a used sphere belongs to a limb that is rigged (a second finger, an ear beside
    the head's path, a bulge of the torso), and extremities that close to one another are one limb."""
    if not candidates:
        return 0
    used_list = sorted(used)
    reach = UNRIGGED_REACH
    distinct: list[int] = []
    for s in candidates:
        if graph.distances[s, used_list].min() <= reach:
            continue
        if any(graph.distances[s, t] <= reach for t in distinct):
            continue
        distinct.append(s)
    return len(distinct)
