"""Why a rig's confidence is low, in words a user can act on: the parts that pulled it down most.

The confidence (``autorig.confidence``) is read, never changed. With a calibrated model (a learned template's
``ConfidenceModel``), each feature moves the model's log-odds by ``coef * (x - mean) / scale``; the ones that
move it down most (below the calibration rigs' average) are the reasons, together with the factors the model's
probability is multiplied by (``beyond_calibration``: fit, limbs, extra, search, sides, feet, reach, forks,
head), each counted by how much it moves the log-odds of the final number. Without a model the confidence is a product of parts, and each part
``p < 1`` pulls it down by ``log p``. Each reason names the joints it is about where the rig says which
("left knee / right knee: not mirror images where the mesh is (9% of the height apart)").

Under ``DOUBTFUL`` a rig is "probably wrong": the summary line, ``--strict``, the batch's reports and its
review page say so and name these reasons.
"""
from __future__ import annotations

import math

import numpy as np

from .confidence import (FEATURES, STRICT_THRESHOLD, WITHIN, ConfidenceModel, _fit_part, features,
                         posture_free_cost_per_bone)
from .embed.penalties import PROMINENCE, prominences

# Below this confidence a rig is "probably wrong: look at the preview" (the calibrated model's 0.5 line, the
# same as where --strict stops: its probability of being right is under even odds).
DOUBTFUL = STRICT_THRESHOLD
# How many reasons a line names, and how small a pull (in log-odds, or log of a product's part) is no reason.
MOST_REASONS = 2
LEAST_PULL = 0.05
PROBABLY_WRONG = "probably wrong: look at the preview"


def is_doubtful(confidence: float | None) -> bool:
    """Whether a rig with this confidence is "probably wrong" (None: a rig without a confidence is not)."""
    return confidence is not None and confidence < DOUBTFUL


def confidence_reasons(field, graph, embedding, template, joints: np.ndarray, parts: dict,
                       confidence: float, toes: float | None = None) -> list[str]:
    """The reasons, strongest first (at most ``MOST_REASONS``), that pulled the confidence of ``joints`` [J, 3]
    (canonical frame) embedded as ``embedding`` down, with the confidence's ``parts`` as ``rig_confidence``
    returned them; [] when nothing pulls it down. toes: ``confidence.toes_forward`` of the mesh and ``joints``
    when the caller has it (None: measured here)."""
    if template.confidence is None:
        pulls = {name: math.log(max(value, 1e-3)) for name, value in parts.items()}
    else:
        model = ConfidenceModel.from_dict(template.confidence)
        free = posture_free_cost_per_bone(embedding, graph, template)
        values = features(parts, free, joints, template, model.bone_log_sigma, field.surface_vertices, toes)
        x = (model.design([values])[0] - model.mean) / model.scale
        pulls = {name: float(c) for name, c in zip(FEATURES, model.coef * x)}
        pulls["cost_per_bone"] = pulls.pop("cost_per_bone") + _factor_pull(confidence, _fit_part(free))
        for name in ("limbs", "extra", "search"):
            pulls[name] += _factor_pull(confidence, parts[name])
        pulls["sides"] = _factor_pull(confidence, parts.get("sides", 1.0))
        pulls["reach"] = _factor_pull(confidence, parts.get("reach", 1.0))
        pulls["forks"] = _factor_pull(confidence, parts.get("forks", 1.0))
        pulls["head"] = _factor_pull(confidence, parts.get("head", 1.0))
        pulls["within"] = _factor_pull(confidence, parts.get("within", 1.0))
        pulls["feet_behind"] += _factor_pull(confidence, parts.get("feet", 1.0))
        pulls["_values"] = values     # not a pull: what the words quote
    values = pulls.pop("_values", {})
    ranked = sorted((pull, name) for name, pull in pulls.items() if pull < -LEAST_PULL)
    return [_words(name, field, graph, embedding, template, joints, parts, values)
            for _, name in ranked[:MOST_REASONS]]


def _factor_pull(final: float, factor: float) -> float:
    """How much multiplying the probability by ``factor`` moved the log-odds of the ``final`` confidence."""
    final = min(max(final, 1e-6), 1 - 1e-6)
    before = min(max(final / max(factor, 1e-6), 1e-6), 1 - 1e-6)
    return math.log(final / (1 - final)) - math.log(before / (1 - before))


def _said(name: str) -> str:
    return name.replace("_", " ")


def _words(name: str, field, graph, embedding, template, joints, parts, values) -> str:
    """One reason in words, naming the joints concerned where it can."""
    if name == "inside":
        solid = [j for j in range(len(template.names)) if not template.is_tip(j)]
        depth = field.depth(joints[solid])
        outside = [template.names[solid[k]] for k in np.argsort(depth) if depth[k] <= 0]
        shown = ", ".join(map(_said, outside[:3])) + (" ..." if len(outside) > 3 else "")
        return f"{shown or 'joints'}: outside the mesh"
    if name == "symmetry" and template.symmetry:
        # The pair the part counts most against: its gap weighted, as the part weighs it, by how much the mesh
        # around the pair is its own mirror image (``refine.pair_symmetry``; a stride's legs are not).
        from .embed.refine import pair_symmetry
        left = np.array([i for i, _ in template.symmetry])
        right = np.array([j for _, j in template.symmetry])
        gaps = np.linalg.norm(joints[left] * [-1, 1, 1] - joints[right], axis=1)
        k = int(np.argmax(pair_symmetry(field, joints, left, right) * gaps))
        return f"{_said(template.names[left[k]])} / {_said(template.names[right[k]])}: not mirror images " \
               f"where the mesh is ({gaps[k]:.0%} of the height apart)"
    if name == "proportions":
        return _proportions_words(template, joints)
    if name == "limbs":
        reduced = template.reduced()
        leaves = [k for k in range(len(reduced.joints)) if k not in set(reduced.parents.tolist())]
        prominence = prominences(graph)
        missed = [template.names[int(reduced.joints[k])] for k in leaves
                  if prominence[int(embedding.spheres[k])] < PROMINENCE]
        return f"{', '.join(map(_said, missed[:3])) or 'limb ends'}: not at an end of the shape"
    if name == "extra":
        return "the shape: has limbs the template left without bones"
    if name == "search":
        return "embedding: the search ran out of time and took a greedy guess"
    if name == "sides":
        from .embed.sides import crossed_pairs
        pairs = crossed_pairs(joints, template)
        named = " and ".join(f"{_said(template.names[i])} / {_said(template.names[j])}" for i, j in pairs[:2])
        return f"{named or 'left and right'}: each on the other's side of the body (a limb's chain crossed over)"
    if name == "reach":
        from .embed.sides import chain_ratios
        chain, ratio = min(chain_ratios(joints, template), key=lambda item: item[1])
        return f"{_said(template.names[chain[0]])} to {_said(template.names[chain[-1]])}: {ratio:.1f}x the " \
               f"template's length (a hand or foot that touches the body can hide the limb's end)"
    if name == "forks":
        from .confidence import passed_forks
        ends = [template.names[j] for j in passed_forks(graph, embedding, template)]
        return f"{', '.join(map(_said, ends[:3])) or 'a limb end'}: at the end of a short fork of the limb (a " \
               f"longer branch of it has no bones)"
    if name == "head":
        from .embed.sides import at_head
        found = sorted(at_head(field, joints, template), key=lambda item: item[1])
        shown = ", ".join(_said(template.names[j]) for j, _ in found[:2])
        near = f" ({found[0][1]:.1f}x the neck and head's length from them)" if found else ""
        return f"{shown or 'a wrist'}: against the neck and head{near}: the arm's chain ran up to the neck " \
               f"(a hand that touches the body can hide the limb's end)"
    if name == "within":
        from .embed.sides import in_limbs
        found = sorted(in_limbs(field, joints, template), key=lambda item: item[1])
        shown = ", ".join(_said(template.names[j]) for j, ratio in found[:2] if ratio < WITHIN or ratio == found[0][1])
        depth = f" ({found[0][1]:.1f}x the other limb's depth from its bone)" if found else ""
        return f"{shown or 'a wrist'}: inside another limb{depth}: the arm's chain ran into a leg (a hand that " \
               f"touches the body can hide the limb's end)"
    if name == "cost_per_bone":
        return "bones: far from the template's lengths and directions"
    if name == "facing":
        return "feet: pointing backwards (left and right swapped?)"
    if name in ("feet_behind", "feet"):
        return "feet: the mesh's toes lie behind its shins (rigged facing backwards?)"
    if name == "ends_short":
        return _ends_words(template, joints, field.surface_vertices)
    if name == "fit":
        return "bones: far from the template's lengths and directions"
    return f"{name}: low"


def _ends_words(template, joints, vertices) -> str:
    """Which of a four-legged rig's ends (its frontmost tip, the head's; its rearmost, the tail's) stops
    furthest short of the mesh's end, as ``autorig.confidence.ends_short`` measures it."""
    tips = [j for j in range(len(template.names)) if template.is_tip(j)]
    z = template.positions[tips, 2]
    front, back = tips[int(np.argmax(z))], tips[int(np.argmin(z))]
    length = max(float(np.ptp(vertices[:, 2])), 1e-12)
    ahead = (float(vertices[:, 2].max()) - joints[front, 2]) / length
    behind = (joints[back, 2] - float(vertices[:, 2].min())) / length
    if ahead >= behind:
        return f"{_said(template.names[front])}: {ahead:.0%} of the body's length short of the front (is the " \
               f"head at the tail end, or in a horn?)"
    return f"{_said(template.names[back])}: {behind:.0%} of the body's length short of the back"


def _proportions_words(template, joints) -> str:
    """The bone whose length is furthest from the template's, as a ratio."""
    child = np.flatnonzero(template.parents >= 0)
    parent = template.parents[child]
    rig = np.linalg.norm(joints[child] - joints[parent], axis=1)
    ref = np.linalg.norm(template.positions[child] - template.positions[parent], axis=1)
    solid = [k for k, c in enumerate(child) if not template.is_tip(int(c)) and ref[k] > 1e-9]
    if not solid:
        return "proportions: unlike the examples'"
    ratio = np.maximum(rig[solid], 1e-9) / ref[solid]
    k = int(np.argmax(np.abs(np.log(ratio))))
    return f"{_said(template.names[int(child[solid[k]])])}: its bone {ratio[k]:.1f}x the examples' length"


def confidence_words(confidence: float | None, reasons: list[str]) -> str:
    """The summary's confidence: "confidence 0.86", or "confidence 0.26, probably wrong: look at the preview
    (head: ...; ...)", or "no confidence (--template auto)" when there is none."""
    if confidence is None:
        return "no confidence (--template auto: no template to check against)"
    text = f"confidence {confidence:.2f}"
    if is_doubtful(confidence):
        text += f", {PROBABLY_WRONG}" + (f" ({'; '.join(reasons)})" if reasons else "")
    return text
