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
symmetry   mirrored joints that are not mirror images where the mesh is (each pair's mismatch weighted by
           ``refine.pair_symmetry``): 1 / (1 + (mean mismatch / 10% of height)^2)
search     0.8 when the A* search ran out of budget and took its greedy embedding
feet       the mesh's toes behind its shins (``toes_forward``), as under a rig made facing backwards:
           1 / (1 + (how far behind / FEET_BEHIND_SCALE)^2); 1 for a template without feet
sides      a mirror pair near the trunk (shoulders and elbows, hips and knees: ``sides.SIDE_DEPTH``) each
           on the other's side, as when an arm's chain crossed to the other arm: 0.5 for each such pair. Hands and
           feet may cross (arms folded, legs crossed); elbows and knees do not
reach      an arm or leg whose chain (shoulder to wrist, hip to toe) is far shorter than the template's, as when
           a hand that touches the body (hands on the hips, on the thighs of a seated figure) hid the limb's
           end and the chain ended at a bump near the shoulder: the product over the side chains of
           1 / (1 + (LIMB_SHORT / length ratio)^12); legs read off the mesh do not count
forks      a side limb's end (a hand, a foot, a paw) whose chain took the lesser fork of its limb, as when a
           seated armoured figure's arm chains ended at bumps behind its shoulders and left its hands, by its
           thighs, without bones (``passed_forks``): FORK_PART for each such end
head       a side limb's end joint (a wrist) against the neck and head, as when hands on the hips hid the arms'
           ends and their chains ran up from the shoulders to the neck (``at_head``): for each end whose
           straight line to the mid-plane chain beside its limb (neck to head tip) stays inside the mesh, its
           distance to that chain over the chain's length ``near`` scores 1 / (1 + (HEAD_NEAR / near)^16)
within     a side limb's end joint (a wrist) within another limb's flesh, as when hands on the hips hid the
           arms' ends and their chains ran down into the thighs (``in_limbs``): its distance to the other
           limb's nearest bone over the mesh's depth there, ``ratio``, scores 1 / (1 + (WITHIN / ratio)^16)
=========  =========================================================================================

Without a model, the confidence is their product. A template learned from examples (``autorig learn``)
carries a *calibrated* model instead (``ConfidenceModel``): a logistic regression, fitted on rigs of the
examples whose true error is known, of the parts above, of how far the rig's proportions are from the
learned ones (``proportions``: mean squared z-score of the bones' log lengths against their spread over the
examples), of whether its feet point the way the template's do (``facing``: a rig made facing backwards, left
and right swapped, has the proportions and costs of a right one; its toes point the wrong way), and of how far
the mesh's feet lie behind its shins (``feet_behind``: a backwards rig whose toe joints went onto the heels
points them the template's way, but the feet it stands on still point the other), and, for a four-legged
template, whether its head and tail chains reach the mesh's front and back (``ends_short``). Its
output is the probability that the rig is right (worst joint within ``GOOD_ERROR`` of the height) rather than
wrong (worst joint more than ``BAD_ERROR`` off), so below 0.5 means "probably wrong" and 0.5 or above "probably
right". Each feature can only move it one way: a better fit, more joints inside, a more symmetric rig
never lower it. The model's probability is then multiplied by the fit, limbs, extra, search, feet and sides parts
(``beyond_calibration``): the failures those stand for are ones no calibration rig shows, so the model cannot
have learned them (``reach``, ``forks``, ``head`` and ``within`` too). ``STRICT_THRESHOLD`` is where ``--strict``
stops a pipeline.
"""
from __future__ import annotations

import numpy as np

from .discretize.distance import DistanceField
from .discretize.graph import SphereGraph
from .embed.penalties import PROMINENCE, prominences
from .embed.sides import at_head, chain_ratios, crossed_pairs, in_limbs
from .embed.search import Embedding
from .template import Template

STRICT_THRESHOLD = 0.5
# Worst joint error (fraction of the height) within which a calibration rig counts as right: the line of "probably
# right" that the confidence is judged by. At 0.15, with the learned placement, quadruped rigs 15-30 % off looked
# like those just under 0.15 and four of eleven bad ones scored 0.5 or more.
GOOD_ERROR = 0.10
# ... and beyond which it counts as wrong. Rigs in between are the ones neither claim is about: the model is
# fitted on right and wrong rigs only, so that its 0.5 line falls between the two rather than on GOOD_ERROR.
BAD_ERROR = 0.20
# Bone directions are left out: they measure the rest pose (the corpus hangs its arms, a T-posed character
# holds them out), not whether the rig is right; so is the direction term of the cost per bone. The feet are
# the exception (``facing``, and ``feet_behind`` for the mesh's own feet): seen from above, toes point forwards
# in any rest pose. Feet in front are no evidence of a right rig, only feet behind of a wrong one: counted as a
# signed offset, small feet read as a wrong rig's (CesiumMan 0.67 -> 0.60), and so would feet a robe hides.
# A four-legged template's head leads and its tail trails: ``ends_short`` is how far the mesh reaches beyond the
# rig's frontmost and rearmost tips (the snout and the tail's end). A head chain that ends short of the snout
# went into a tusk, a horn or the neck (cross-validated corpus rigs within 12 % of their worst limb joint fell
# short by at most 6 % of the body's length; the boar, pig and tiger, 20-28 % off, by 12-19 %).
FEATURES = ("cost_per_bone", "limbs", "extra", "inside", "symmetry", "search", "proportions", "facing",
            "feet_behind", "ends_short")
UNRIGGED_REACH = 0.25    # an end nearer than this (height units) to the rigged skeleton belongs to a rigged limb
LIMB_LIKE = 0.6          # an unused end counts as a limb when it stands out this much of the rigged ones
FIT_SCALE = 0.5          # embedding penalty per reduced bone at which the fit part is 1/2
# Where ``toes_forward`` looks, as fractions of the height, by a standing figure's build (an ankle sits some 4-5 %
# of the height up, a knee about 28 %; a foot is some 15 % of the height long): the feet are the mesh below
# FOOT_BAND, the shins between SHIN_BAND's bounds, each within FOOT_REACH (seen from above) of the rig's ankle.
FOOT_BAND = 0.04
SHIN_BAND = (0.10, 0.25)
FOOT_REACH = 0.15
# ``feet``: how far behind its shins (heights) the mesh's feet lie for the part to be 1/2. No right rig of the
# shared and corpus bipeds, in their rest poses or re-posed (benchmarks/poses.py), has its mesh's feet behind
# its shins at all (0.000 each); the mannequins rigged facing backwards, 0.037-0.047. The calibrated model
# weighs it too, but on too few backwards rigs: an A-posed mannequin rigged facing backwards scored 0.64.
FEET_BEHIND_SCALE = 0.02
# ``reach``: a side limb's chain this fraction of the template's length scores 1/2, falling steeply below
# (power 12: 0.33 -> 0.09, 0.47 -> 0.87, 0.6 -> 0.99). Over the 81 rest-pose bipeds of benchmarks/stability.py
# every arm and leg chain is 0.69-1.9 of the template's; over the 74 corpus and shared bipeds re-posed by
# benchmarks/poses.py --all (seven poses, 518 rigs, default convention, c502ed3), the 484 right ones 0.47 or more
# but for one (0.31, a wrist 14 % of the height off), while 11 of the 34 wrong ones (hands on the hips, a
# seated figure's hands on its thighs: wrists at the shoulders or the head) had an arm at 0.26-0.47.
LIMB_SHORT = 0.4
# ``forks``: what each side limb end on the lesser fork of its limb multiplies the confidence by (as ``sides``
# does for each crossed pair). Over the 518 rigs of ``benchmarks/poses.py --all`` (4bc6bec, scratch) the rule
# finds one such end pair, on a wrong rig (an armoured 0 A.D. body seated, both hands' ends on bumps behind the
# shoulders: 0.60 -> 0.15), and none on the 488 right rigs nor on the 112 rest-pose characters of
# ``benchmarks/stability.py``.
FORK_PART = 0.5
# ``head``: a side limb's end joint this near the mid-plane chain beside its limb (neck, head, head tip), as a
# fraction of that chain's length, scores 1/2 (power 16: 0.6 -> 0.08, 0.7 -> 0.25, 0.8 -> 0.74, 1.0 -> 0.99),
# counted only when the straight line between them stays inside the mesh (``HEAD_JOINED``): a hand raised beside
# the head has air between. Over the 518 rigs of ``benchmarks/poses.py --all`` (all seven poses, f3d3c47,
# scratch), 21 of the 25 wrong "hands on hips" rigs had a wrist within 0.94 of the chain's length, the wrist by
# the neck (the arm's chain ran up from the shoulder), and 10 of them scored 0.5 or more (0.63-0.86) with their
# nearer wrist at 0.05-0.73. Of the 986 right rigs' wrists, those joined to the chain through the mesh lie 0.79
# or more from it (0 A.D.'s spearman, hands on hips, its chain ended at the elbow's point: confidence 0.499 before),
# then 1.01 or more; a raised hand beside the head, 0.42, has air between (22 % of the line outside the mesh).
HEAD_NEAR = 0.75
HEAD_POWER = 16
# ``within``: a side limb's end at this distance from another limb's bone, over the mesh's depth at the bone's
# nearest point (about that limb's radius there), scores 1/2 (power 16, as ``head``): 1 is the other limb's
# surface, below it the end lies in its flesh. Over the 518 rigs of ``benchmarks/poses.py --all`` (seven poses,
# f3b9dc5, scratch), four wrong "hands on hips" rigs had a wrist in a thigh at 0.61-0.97 (their arm chains ran
# down into the legs; confidence 0.51-0.88 -> 0.00-0.18); the nearest right rigs' wrists, 1.05-1.06, are hands
# pressed into the hips whose worst joints are 9.8 and 14.4 % of the height off (0.82 -> 0.56, 0.88 -> 0.46);
# over the 74 rest-pose bipeds every wrist lies 3.3 or more.
WITHIN = 1.0


def rig_confidence(field: DistanceField, graph: SphereGraph, embedding: Embedding, template: Template,
                   joints: np.ndarray, toes: float | None = None) -> tuple[float, dict[str, float]]:
    """(confidence, {part: value}) for ``joints`` [J, 3] (canonical frame) embedded as ``embedding``. toes:
    ``toes_forward`` of the mesh and ``joints`` when the caller has it (None: measured here)."""
    reduced = template.reduced()
    leaves = [k for k in range(len(reduced.joints)) if k not in set(reduced.parents.tolist())]
    per_bone = embedding.cost / max(len(reduced.joints) - 1, 1)
    prominence = prominences(graph)
    ends = set(np.flatnonzero(prominence >= PROMINENCE).tolist())
    placed = [int(embedding.spheres[k]) for k in leaves]
    used_spheres = {s for path in embedding.paths for s in path}
    # Only ends that stand out about as much as the template's own limbs count as limbs left unrigged (an
    # octopus's other tentacles), not ears or the bumps of a low-poly model.
    unrigged = _unrigged_ends(prominence, ends, placed, used_spheres)
    unused_ends = _count_distinct_ends(graph, unrigged, used_spheres)

    solid = [j for j in range(len(template.names)) if not template.is_tip(j)]
    inside = float(np.mean(field.depth(joints[solid]) > 0))
    vertices = field.surface_vertices
    if toes is None:
        toes = toes_forward(vertices, joints, template)
    if template.symmetry:
        left = np.array([i for i, _ in template.symmetry])
        right = np.array([j for _, j in template.symmetry])
        # Counted where the mesh is its own mirror image (``refine.pair_symmetry``): a stride's legs are not.
        from .embed.refine import pair_symmetry
        weight = pair_symmetry(field, joints, left, right)
        mismatch = float(np.mean(weight * np.linalg.norm(joints[left] * [-1, 1, 1] - joints[right], axis=1)))
    else:
        mismatch = 0.0
    parts = {
        "fit": _fit_part(per_bone),
        "limbs": float(np.mean([s in ends for s in placed])),
        "extra": 1.0 / (1.0 + unused_ends / len(leaves)),
        "inside": inside,
        "symmetry": 1.0 / (1.0 + (mismatch / 0.1) ** 2),
        "search": 1.0 if embedding.optimal else 0.8,
        "sides": 0.5 ** len(crossed_pairs(joints, template)),
        "feet": 1.0 / (1.0 + (max(-toes, 0.0) / FEET_BEHIND_SCALE) ** 2),
        "reach": reach_part(joints, template),
        "forks": FORK_PART ** len(passed_forks(graph, embedding, template)),
        "head": head_part(field, joints, template),
        "within": within_part(field, joints, template),
    }
    if template.confidence is None:
        return float(np.prod(list(parts.values()))), {k: round(float(v), 3) for k, v in parts.items()}
    model = ConfidenceModel.from_dict(template.confidence)
    free_per_bone = posture_free_cost_per_bone(embedding, graph, template)
    values = features(parts, free_per_bone, joints, template, model.bone_log_sigma, vertices, toes)
    # The rig's info shows the fit this confidence used: without the direction term and a read-off leg's length.
    parts["fit"] = _fit_part(free_per_bone)
    return (model.probability(values) * beyond_calibration(parts, free_per_bone),
            {k: round(float(v), 3) for k, v in parts.items()})


def beyond_calibration(parts: dict, free_per_bone: float) -> float:
    """What a calibrated model multiplies its probability by: the formula's parts for failures the calibration
    rigs never show, and so cannot teach it (their rigs fit, find their limbs and finish their search; a
    limbless torso embedded with a cost per bone ten times theirs and limb ends on bumps scored 0.52 without
    this). The fit is taken without the direction term, like the model's cost (a T pose is no failure). On the
    corpus's cross-validated biped rigs it moves no confidence by more than 0.01."""
    return float(_fit_part(free_per_bone) * parts["limbs"] * parts["extra"] * parts["search"]
                 * parts.get("sides", 1.0) * parts.get("feet", 1.0) * parts.get("reach", 1.0)
                 * parts.get("forks", 1.0) * parts.get("head", 1.0) * parts.get("within", 1.0))


def _unrigged_ends(prominence: np.ndarray, ends: set, placed: list[int], used: set) -> list[int]:
    """The ``ends`` (spheres) off every embedded path (``used``) that stand out at least ``LIMB_LIKE`` as much as
    the template's limb ends (the ``placed`` spheres; median, prominences above 1 counted as 1), in sphere order:
    only those count as limbs left unrigged (an octopus's other tentacles), not ears or the bumps of a low-poly
    model."""
    limb_like = LIMB_LIKE * float(np.median(np.minimum(prominence[placed], 1.0)))
    return sorted(s for s in ends - used if prominence[s] >= limb_like)


def passed_forks(graph: SphereGraph, embedding: Embedding, template: Template) -> list[int]:
    """The template's side limb ends (the reduced skeleton's leaves with a mirror image: hands, feet, paws; joint
    indices, ascending) whose chain took the lesser fork of its limb: an end of the shape left without bones (as
    ``extra`` counts them: standing out like a limb, farther than ``UNRIGGED_REACH`` from every embedded path)
    branches off that end's path, and no other's, at least ``PROMINENCE`` before the end's sphere, runs farther
    from the fork than the end's sphere does, and stands out more. A seated armoured figure: its arm chains went
    to bumps behind its shoulders (prominence 0.12), its hands (the two most prominent ends of the shape) branch
    off those paths at the shoulders. A prop held in a hand branches off at the hand (no fork before the end), a
    horn, an ear or a ponytail off the head (no side limb's path): ``extra`` counts those."""
    reduced = template.reduced()
    parents = set(reduced.parents.tolist())
    mirror = template.mirror_of()
    prominence = prominences(graph)
    placed = [int(embedding.spheres[k]) for k in range(len(reduced.joints)) if k not in parents]
    used = sorted({s for path in embedding.paths for s in path})
    unrigged = _unrigged_ends(prominence, set(np.flatnonzero(prominence >= PROMINENCE).tolist()), placed,
                              set(used))
    holders: dict[int, set[int]] = {}           # sphere -> the reduced joints whose bone's path holds it
    for k, path in enumerate(embedding.paths[1:], start=1):
        for s in path:
            holders.setdefault(int(s), set()).add(k)
    passed = set()
    for u in unrigged:
        gaps = np.asarray(graph.distances[u, used], dtype=float)
        nearest = int(np.argmin(gaps))
        fork = used[nearest]
        if gaps[nearest] <= UNRIGGED_REACH or len(holders.get(fork, ())) != 1:
            continue
        (k,) = holders[fork]
        joint = int(reduced.joints[k])
        if k in parents or mirror[joint] == joint:
            continue
        end = int(embedding.spheres[k])
        along = float(graph.distances[fork, end])
        if PROMINENCE <= along < gaps[nearest] and prominence[u] > prominence[end]:
            passed.add(joint)
    return sorted(passed)


def head_part(field: DistanceField, joints: np.ndarray, template: Template) -> float:
    """The ``head`` part: 1 / (1 + (HEAD_NEAR / near)^HEAD_POWER) over ``at_head``'s ends."""
    return float(np.prod([1.0 / (1.0 + (HEAD_NEAR / max(near, 1e-9)) ** HEAD_POWER)
                          for _, near in at_head(field, joints, template)]))


def within_part(field: DistanceField, joints: np.ndarray, template: Template) -> float:
    """The ``within`` part: 1 / (1 + (WITHIN / ratio)^HEAD_POWER) over ``in_limbs``' ends (the ``head`` part's
    power: both stand for a limb's chain that ran into another part of the body)."""
    return float(np.prod([1.0 / (1.0 + (WITHIN / max(ratio, 1e-9)) ** HEAD_POWER)
                          for _, ratio in in_limbs(field, joints, template)]))


def reach_part(joints: np.ndarray, template: Template) -> float:
    """The ``reach`` part: 1 / (1 + (LIMB_SHORT / ratio)^12) over the side chains' ``chain_ratios``."""
    return float(np.prod([1.0 / (1.0 + (LIMB_SHORT / max(ratio, 1e-9)) ** 12)
                          for _, ratio in chain_ratios(joints, template)]))


def _fit_part(per_bone: float) -> float:
    """The fit part of an embedding penalty per reduced bone: 1/2 at ``FIT_SCALE``, falling fast beyond it."""
    return 1.0 / (1.0 + (per_bone / FIT_SCALE) ** 4)


def posture_free_cost_per_bone(embedding: Embedding, graph: SphereGraph, template: Template) -> float:
    """The model's ``cost_per_bone``: the embedding's penalty without its direction term, per reduced bone. A
    T-posed character against a template whose arms hang pays direction penalties for its rest pose, not for
    being wrongly rigged (the same reason bone directions are no feature)."""
    from .embed.penalties import WEIGHTS, bone_vectors, direction_term
    reduced = template.reduced()
    weights = template.penalty_weights or WEIGHTS
    spheres = [int(s) for s in embedding.spheres]
    free = weights["direction"] * direction_term(graph.centers, spheres, reduced.parents,
                                                 bone_vectors(template, reduced))
    if template.legs:
        # Nor, for a template whose legs are read off the mesh, the legs' length term: a short-legged animal's
        # legs are short in a right rig too (spot, a cartoon cow: cost per bone 0.60, of which its legs 0.34).
        from .readoff.legs import legs_of
        feet = {chain[-1] for chain in legs_of(template)}
        for k in range(1, len(spheres)):
            if int(reduced.joints[k]) in feet:
                path = max(float(graph.distances[spheres[reduced.parents[k]], spheres[k]]), 1e-9)
                free += weights["length"] * (np.log(path) - np.log(reduced.lengths[k])) ** 2
    return max(float(embedding.cost) - free, 0.0) / max(len(reduced.joints) - 1, 1)


def features(parts: dict, per_bone: float, joints: np.ndarray, template: Template,
             bone_log_sigma: np.ndarray, vertices: np.ndarray, toes: float | None = None) -> dict[str, float]:
    """{feature: value} of ``FEATURES`` for a rig's ``joints`` [J, 3] of the mesh with ``vertices`` [V, 3]
    (both in the canonical frame) with confidence ``parts``; ``bone_log_sigma`` [J] is the spread over the
    examples of each joint's incoming bone's log length (entry 0, the root's, unused). toes: ``toes_forward``
    of the mesh and joints when the caller has it (None: measured here)."""
    child = np.flatnonzero(template.parents >= 0)
    parent = template.parents[child]
    rig = joints[child] - joints[parent]
    ref = template.positions[child] - template.positions[parent]
    rig_length = np.maximum(np.linalg.norm(rig, axis=1), 1e-9)
    ref_length = np.maximum(np.linalg.norm(ref, axis=1), 1e-9)
    z = np.log(rig_length / ref_length) / np.maximum(bone_log_sigma[child], 0.05)
    if template.legs:
        # Legs read off the mesh are the animal's own: a short-legged one's are short in a right rig too (corpus
        # animals with their legs squeezed to 0.6 kept their rigs and lost a quarter of their confidence).
        from .readoff.legs import legs_of
        read = {j for chain in legs_of(template) for j in chain[1:]}
        z = z[[c not in read for c in child]]
    return {"cost_per_bone": float(per_bone), "limbs": parts["limbs"], "extra": parts["extra"],
            "inside": parts["inside"], "symmetry": parts["symmetry"], "search": parts["search"],
            "proportions": float(np.mean(z ** 2)) if len(z) else 0.0, "facing": feet_facing(joints, template),
            "feet_behind": max(-(toes_forward(vertices, joints, template) if toes is None else toes), 0.0),
            "ends_short": ends_short(vertices, joints, template)}


def ends_short(vertices: np.ndarray, joints: np.ndarray, template: Template) -> float:
    """For a template with learned legs (four-legged), the larger of how far the mesh (``vertices`` [V, 3])
    reaches in front of the rig's frontmost tip and behind its rearmost (the template's tips with the largest
    and smallest z; ``joints`` [J, 3]; both in the canonical frame, facing +z), as a fraction of the mesh's
    length; 0 for other templates (a biped's front is its toes or its belly, neither a chain's end) or no
    mesh."""
    tips = [j for j in range(len(template.names)) if template.is_tip(j)]
    if not template.legs or len(vertices) == 0 or len(tips) < 2:
        return 0.0
    length = float(np.ptp(vertices[:, 2]))
    if length <= 0:
        return 0.0
    z = template.positions[tips, 2]
    front, back = tips[int(np.argmax(z))], tips[int(np.argmin(z))]
    gap = max(float(vertices[:, 2].max() - joints[front, 2]), float(joints[back, 2] - vertices[:, 2].min()))
    return max(gap, 0.0) / length


def feet_facing(joints: np.ndarray, template: Template) -> float:
    """In [0, 1]: how nearly the rig's feet (``joints`` [J, 3], canonical frame) point the way the template's
    do, seen from above: each foot's last bone but its tip's (ankle to toe), its horizontal part against the
    template's, cos 1 for the same way, -1 for the opposite, weighted by the two parts' lengths and mapped to
    (1 + cos) / 2. A paw's bone, nearly vertical, weighs little; 1 for a template without feet."""
    num = den = 0.0
    for start, end in _foot_bones(template):
        rig = (joints[end] - joints[start])[[0, 2]]
        ref = (template.positions[end] - template.positions[start])[[0, 2]]
        num += float(rig @ ref)
        den += float(np.linalg.norm(rig) * np.linalg.norm(ref))
    return 1.0 if den < 1e-12 else max((1.0 + num / den) / 2, 0.0)


def _foot_bones(template: Template) -> list[tuple[int, int]]:
    """(ankle, toe) joint indices of each of the template's feet: its last bone but its tip's."""
    bones = []
    for foot in template.feet:
        end = template.parents[foot] if template.is_tip(foot) else foot
        if template.parents[end] >= 0:
            bones.append((int(template.parents[end]), int(end)))
    return bones


def toes_forward(vertices: np.ndarray, joints: np.ndarray, template: Template) -> float:
    """How far the mesh's feet lie in front of its shins (+z, the way the template faces), as a fraction of the
    height, averaged over the template's feet: for each, the mean of the mesh's vertices [V, 3] below
    ``FOOT_BAND`` minus the mean of those in ``SHIN_BAND``, both within ``FOOT_REACH`` of the rig's ankle (the
    joint the foot's last bone starts from; ``joints`` [J, 3], canonical frame), seen from above. Positive for a
    figure rigged facing the way it stands, negative for one rigged facing backwards, wherever its toe joints
    went; 0 for a template without feet or with no mesh about the ankles."""
    if len(vertices) == 0:
        return 0.0
    floor, height = float(vertices[:, 1].min()), float(np.ptp(vertices[:, 1]))
    if height <= 0:
        return 0.0
    up = (vertices[:, 1] - floor) / height
    feet = up < FOOT_BAND
    shins = (up > SHIN_BAND[0]) & (up < SHIN_BAND[1])
    offsets = []
    for ankle, _ in _foot_bones(template):
        near = np.linalg.norm((vertices - joints[ankle])[:, [0, 2]], axis=1) < FOOT_REACH * height
        if (near & feet).sum() < 2 or (near & shins).sum() < 2:
            continue
        offsets.append((vertices[near & feet, 2].mean() - vertices[near & shins, 2].mean()) / height)
    return float(np.mean(offsets)) if offsets else 0.0


class ConfidenceModel:
    """A logistic regression of ``FEATURES`` (each transformed by ``_transform`` and standardised):
    P(worst joint error <= GOOD_ERROR) = 1 / (1 + exp(-(coef . x + intercept)))."""

    def __init__(self, coef, intercept, mean, scale, bone_log_sigma, record=None):
        self.coef = np.asarray(coef, float)
        self.intercept = float(intercept)
        self.mean = np.asarray(mean, float)
        self.scale = np.asarray(scale, float)
        self.bone_log_sigma = np.asarray(bone_log_sigma, float)
        self.record = record or {}

    @staticmethod
    def design(rows: list[dict]) -> np.ndarray:
        """[N, F] the transformed features of ``rows`` (dicts of ``FEATURES``)."""
        return np.array([[_transform(name, row[name]) for name in FEATURES] for row in rows], dtype=float)

    def probability(self, row: dict) -> float:
        x = (self.design([row])[0] - self.mean) / self.scale
        return float(1.0 / (1.0 + np.exp(-(x @ self.coef + self.intercept))))

    def to_dict(self) -> dict:
        return {"kind": "logistic", "good_error": GOOD_ERROR, "features": list(FEATURES),
                "coef": [round(float(v), 5) for v in self.coef], "intercept": round(self.intercept, 5),
                "mean": [round(float(v), 5) for v in self.mean], "scale": [round(float(v), 5) for v in self.scale],
                "bone_log_sigma": [round(float(v), 4) for v in self.bone_log_sigma], **self.record}

    @classmethod
    def from_dict(cls, data: dict) -> "ConfidenceModel":
        from .errors import TemplateError
        try:
            named = list(data["features"])
            if named != list(FEATURES)[:len(named)]:
                raise ValueError(f"features {named} are not {list(FEATURES)}")
            # A model learned before the later features existed gives them no weight.
            missing = len(FEATURES) - len(named)
            model = cls(list(data["coef"]) + [0.0] * missing, data["intercept"],
                        list(data["mean"]) + [0.0] * missing, list(data["scale"]) + [1.0] * missing,
                        data["bone_log_sigma"])
            if not (len(model.coef) == len(model.mean) == len(model.scale) == len(FEATURES)):
                raise ValueError("coefficient counts differ")
        except (KeyError, TypeError, ValueError) as e:
            raise TemplateError(f"template confidence model: {e}") from None
        return model


def _transform(name: str, value: float) -> float:
    """Parts in (0, 1] by their log (a product becomes a sum); the costs and deviations by log1p."""
    if name in ("cost_per_bone", "proportions", "feet_behind", "ends_short"):
        return float(np.log1p(max(value, 0.0)))
    return float(np.log(max(value, 1e-3)))


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
