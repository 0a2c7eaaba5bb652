"""The confidence model of a learned template, calibrated on rigs of the examples whose error is known.

The rigs are made as ``autorig.rig`` makes them, minus the skin weights, with templates that did not see the
example (its fold of the examples left out of the proportions), in the example's own frame, facing the wrong
way, and re-proportioned (``augment``), so that the model sees rigs that are right and rigs that are wrong, of
characters built like the examples and unlike them. Each is labelled by its worst
joint error over the joints the example has; the model is a logistic regression of ``confidence.FEATURES``
for P(worst error <= GOOD_ERROR) against worst error > BAD_ERROR, fitted with scipy (L-BFGS-B, a small L2 pull
on the coefficients) on the rigs that are one or the other.

Each coefficient's sign is fixed by what its feature means (``SIGNS``): the calibration rigs are few (four per
example), and unconstrained, the fit found that a *less* symmetric rig is more likely right (the backwards
rigs it learned from are symmetric), and a lying-down rig 55 % off then scored 1.0.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..confidence import (BAD_ERROR, FEATURES, GOOD_ERROR, ConfidenceModel, features,
                          posture_free_cost_per_bone, rig_confidence)

L2 = 0.05
# Transformed units (a part's log, a cost's log1p): the least spread a feature is standardised by. A feature the
# calibration rigs barely vary would otherwise weigh a rig outside their range many times over: once the sides
# penalty left no calibration rig with a leg in another leg, every one was symmetric (spread 0.003), and a
# walking animal's right rig, its legs no mirror images, scored 0.00 (a part of 0.92: 29 spreads out).
MIN_SCALE = 0.05
# The way each feature may move the confidence: costs and deviations only lower it, the parts in (0, 1] (1: no
# sign of trouble) only raise it.
SIGNS = {"cost_per_bone": -1, "proportions": -1, "limbs": 1, "extra": 1, "inside": 1, "symmetry": 1, "search": 1,
         "facing": 1, "feet_behind": -1, "ends_short": -1}


@dataclass
class Sample:
    """A calibration rig: the embedding, its refined joints [J, 3] (before the learned placement), the
    confidence parts, and the truth [J, 3] with the joints that count (``scored`` [J] bool); the mesh's box
    ``extent`` [3] and its neck's height fraction (``landmarks.neck_fraction``), for the placement."""
    field: object
    graph: object
    embedding: object
    refined: np.ndarray
    truth: np.ndarray
    scored: np.ndarray
    own_frame: bool
    extent: np.ndarray
    neck: float | None = None


def rig_sample(field, graph, template, truth: np.ndarray, scored: np.ndarray, own_frame: bool,
               extent: np.ndarray) -> Sample | None:
    """``template`` embedded and refined on (field, graph) by ``autorig.rig``'s own stages
    (``pipeline.embed_and_refine``), with the learner's search budget; None if it does not fit."""
    from ..errors import RigFailedError
    from ..readoff.landmarks import neck_fraction
    from ..pipeline import embed_and_refine
    from .gamma import SEARCH_BUDGET
    try:
        embedding, joints = embed_and_refine(field, graph, template, max_expansions=SEARCH_BUDGET)
    except RigFailedError:
        return None
    return Sample(field, graph, embedding, joints, truth, scored, own_frame, extent, neck_fraction(field))


def sample_row(sample: Sample, template, bone_log_sigma: np.ndarray, convention: str | None = None
               ) -> tuple[dict, float]:
    """(feature row, worst joint error) of a calibration rig after ``template``'s learned placement (the
    pipeline's placement stage), in the ``convention`` of the example's artist (the template's default if it
    does not know that one), and with its legs read off the mesh when the template has learned legs (then the
    worst error leaves out the trunk joints whose place is a convention, ``legs.CONVENTION_JOINTS``)."""
    from ..embed.convention import convention_shift, in_convention
    from ..embed.placement import learned_placement
    known = convention if convention in (template.conventions or {}) else None
    joints = learned_placement(sample.refined, template, sample.extent, sample.field,
                               shift=convention_shift(template, known), neck=sample.neck)
    joints = in_convention(joints, template, known, sample.field)
    scored = sample.scored
    if template.legs:    # as the pipeline's legs stage places them, judged apart from the trunk's convention
        from ..readoff.legs import limb_joints, read_legs, surface_of
        from ..readoff.head import read_head
        from ..readoff.rump import read_rump
        joints = read_legs(joints, template, *surface_of(sample.field))
        joints = read_rump(joints, template, sample.field.depth, surface_of(sample.field)[0])
        joints = read_head(joints, template, sample.field.depth, surface_of(sample.field)[0])
        scored = scored & limb_joints(template)
    _, parts = rig_confidence(sample.field, sample.graph, sample.embedding, _without_model(template), joints)
    row = features(parts, posture_free_cost_per_bone(sample.embedding, sample.graph, template), joints, template,
                   bone_log_sigma, sample.field.surface_vertices)
    worst = float(np.max(np.linalg.norm(joints[scored] - sample.truth[scored], axis=1)))
    return row, worst


def fit(rows: list[dict], worst: np.ndarray, bone_log_sigma: np.ndarray) -> ConfidenceModel:
    """The logistic model of P(worst <= GOOD_ERROR) against worst > BAD_ERROR given the feature ``rows``; rows
    in between take no part in the fit (unless every row is in between)."""
    from scipy.optimize import minimize
    worst = np.asarray(worst, dtype=float)
    decided = (worst <= GOOD_ERROR) | (worst > BAD_ERROR)
    if not decided.any():
        decided[:] = True
    rows, worst = [r for r, d in zip(rows, decided) if d], worst[decided]
    X = ConfidenceModel.design(rows)
    mean, scale = X.mean(axis=0), X.std(axis=0)
    scale = np.where(scale < 1e-6, 1.0, np.maximum(scale, MIN_SCALE))
    Z = (X - mean) / scale
    y = (np.asarray(worst) <= GOOD_ERROR).astype(float)
    # Both classes weigh the same however many rigs each has (most rigs of a good template are right).
    positives = max(y.sum(), 1.0)
    negatives = max(len(y) - y.sum(), 1.0)
    w = np.where(y > 0, 0.5 / positives, 0.5 / negatives)

    def objective(theta):
        coef, intercept = theta[:-1], theta[-1]
        t = Z @ coef + intercept
        p = 1.0 / (1.0 + np.exp(-t))
        value = float(w @ (np.logaddexp(0.0, t) - y * t)) + L2 * float(coef @ coef)
        grad_t = w * (p - y)
        grad = np.concatenate([Z.T @ grad_t + 2 * L2 * coef, [grad_t.sum()]])
        return value, grad

    if 0 < y.sum() < len(y):
        bounds = [(None, 0.0) if SIGNS[f] < 0 else (0.0, None) for f in FEATURES] + [(None, None)]
        result = minimize(objective, np.zeros(len(FEATURES) + 1), jac=True, method="L-BFGS-B", bounds=bounds)
        coef, intercept = result.x[:-1], result.x[-1]
    else:
        # Every calibration rig right (or every one wrong): the features cannot tell, the rate can. The
        # template's rigs get the (smoothed) share of right rigs it had, whatever they look like.
        rate = (y.sum() + 0.5) / (len(y) + 1.0)
        coef, intercept = np.zeros(len(FEATURES)), float(np.log(rate / (1 - rate)))
    model = ConfidenceModel(coef, intercept, mean, scale, bone_log_sigma)
    predicted = np.array([model.probability(r) for r in rows])
    model.record = {"calibration_rigs": int(len(decided)), "right_rigs": int(y.sum()),
                    "wrong_rigs": int(len(y) - y.sum()), "misjudged": int(np.sum((predicted >= 0.5) != (y > 0)))}
    return model


def _without_model(template):
    from dataclasses import replace
    return replace(template, confidence=None)
