"""How much orientation detection should trust the head/tail cues, learned from the examples.

Detection (``autorig.embed.orient``) ranks candidate frames by embedding penalty plus a prior: the glTF convention's
handicap plus what the weighted cues (``orient.weighted_cues``) hold against the frame (``orient.cue_penalty``:
how much more they favour the frame with the same up facing the other way). The cues are ``head_tail`` times the
outline's cue (``orient.head_tail_cue``), ``head_bulk`` times the limb ends' bulk (``ends.end_bulk_cue``),
``head_share`` times the weight share (``ends.weight_share_cue``), ``head_crest`` times the crest's place
(``orient.crest_cue``) and ``head_toes`` times the feet's (``ends.toes_cue``). For a four-legged template the
embedding facing backwards often costs less than the right one, so front and back are the cues' to tell; for a
biped the embedding tells them apart and the cues (meant for a head on a neck, on a four-legged body) are noise.
The weights are learned from exactly that: for every example,
facing backwards (the only frame the cues can help the example's own frame against) must lose by a margin,

    (cost(back) - w . cues(back)) - (cost(own) - w . cues(own)) >= MARGIN,

where cost is the penalty of the embedding detection would find in that frame (searched long, as detection
searches its two best frames), and cost(back) - cost(own) counts at most the bound ``head_gap``
(``orient.bounded_costs``), learned with ``w``: of the bounds in ``GAPS`` the one whose weights leave the least
mean squared violation. On the four-legged corpus that is 0 for the quadruped, 0.5 for the horse: the
embedding's difference between an animal facing forwards and backwards says little the cues do not say better
(alone it faces 9 of the 31 corpus animals the right way). The convention's handicap is left out: the corpus is
in the convention, users' files need not be. ``w`` minimises the mean squared violation plus a small pull
towards 0 (a cue that does not help should not weigh).
"""
from __future__ import annotations

import numpy as np

# Measured (detected axes, each animal in four turns: right/reversed/other; templates/retrain.sh learns from the
# 0 A.D. animals, the glTF fox and Quaternius' animals; OpenClonk's wipf, mooq and puka are never learned from):
#   learned on all:                 0 A.D. 64/0/0, fox 4/0/0, Quaternius 43/0/1, OpenClonk 8/4/0
#   learned on 0 A.D. + fox only:   Quaternius 38/6/0 (its fox 0/4, its wolf 2/2), OpenClonk 8/4/0
#   learned on Quaternius only:     0 A.D. 61/3/0 (the pig), fox 4/0/0, OpenClonk 8/4/0
#   before (outline and bulk, the embedding's difference in full, learned on 0 A.D. + fox): 0 A.D. 61/3/0,
#   fox 4/0/0, Quaternius 30/13/1, OpenClonk 4/8/0. The puka (a tail raised above its head) stays reversed.
#   Its outline and crest cues read its thin tail (-0.91 and -1.0; bulk and share +0.37 each). Read without
#   the parts thinner than a share t of the widest medial sphere (vertex by vertex or sphere by sphere), they
#   face it the right way at t = 0.25-0.3 and not at 0.2, and at 0.3 the Quaternius fox (a thick tail reaching
#   far, a head low) comes out reversed when Quaternius is held out: with four weights refitted per group
#   (scratch, the objective above without the embedding), too narrow a window to trust; not kept.
# Those were the four cues on c23e7ea. With the feet's (``ends.toes_cue``, fcb45e8), which weighs most (the
# shipped quadruped 0.42, the other four 0.03-0.12), benchmarks/animals.py --axes detected, each animal's
# template learned without its species or its source, in three turns (as built, facing -z, Z up): 31/31
# each way, the puka included (30/31 before); with the head low 26/31 and 24/31 (22 and 20 before), none turned
# round (5 and 6 before).
MARGIN = 1.0       # penalty units a wrong frame must lose by (group cross-validation over the corpus
                   # animals: at 0.5 one of 64 turned animals came out reversed, at 1.0 none)
PULL = 0.01        # pull of each weight towards 0, per unit of its square, against the mean squared violation
MAX_WEIGHT = 5.0   # the cues are in [-1, 1]; beyond this one would outweigh any embedding
CUES = ("head_tail", "head_bulk", "head_share", "head_crest", "head_toes")   # the weights, in the cue columns' order
GAPS = (0.0, 0.1, 0.25, 0.5, 1.0, 2.0, None)   # the bounds on the front/back embedding difference tried (None: none)


def learn_head_tail(settings, cues, template) -> tuple[dict[str, float], dict]:
    """({template field: weight} of the cues in ``CUES`` and ``head_gap``, record) for ``template`` from the
    examples' ``settings`` (``gamma.Setting``, every frame of every example) and the outline's head/tail cue
    [len(settings)] of each (the bulk, share and crest cues are read off each setting here). The record counts
    the examples whose own frame does not win clearly (by MARGIN) over facing backwards without the cues (nor
    the bound) and with them."""
    from scipy.optimize import minimize

    from ..embed.ends import end_bulk_cue, toes_cue, weight_share_cue
    from ..embed.orient import DECISION_EXPANSIONS, DETECTION_EXPANSIONS, _embedding_cost, _problem, crest_cue
    # Facing backwards is what detection compares on a long search; the other frames it ranks on a short one.
    costs = np.array([_embedding_cost(_problem(s.graph, template), DECISION_EXPANSIONS if s.frame in ("own", "back")
                                      else DETECTION_EXPANSIONS)[0] for s in settings])
    values = np.c_[np.asarray(cues, dtype=float),
                   [end_bulk_cue(s.graph, s.field.surface_vertices) for s in settings],
                   [weight_share_cue(s.graph, s.field.surface_vertices) for s in settings],
                   [crest_cue(s.field.surface_vertices) for s in settings],
                   [toes_cue(s.graph, s.field.surface_vertices, s.field.surface_faces)
                    for s in settings]]   # [N, len(CUES)]
    own = {s.example: n for n, s in enumerate(settings) if s.true_frame and np.isfinite(costs[n])}
    gaps, cue_gaps, examples, backwards = [], [], [], []
    for n, s in enumerate(settings):
        if s.true_frame or s.example not in own or not np.isfinite(costs[n]):
            continue
        o = own[s.example]
        gaps.append(costs[n] - costs[o])
        cue_gaps.append(values[o] - values[n])
        examples.append(s.example)
        backwards.append(s.frame == "back")
    if not gaps:
        return {**{key: 0.0 for key in CUES}, "head_gap": None}, {"skipped": "no frames to compare"}
    gaps, cue_gaps, examples = np.array(gaps), np.array(cue_gaps), np.array(examples)
    backwards = np.array(backwards, dtype=bool)
    # Facing backwards, once per example, every example the same (the other frames: see the module docstring).
    if not backwards.any():
        return {**{key: 0.0 for key in CUES}, "head_gap": None}, {"skipped": "no frames facing backwards"}
    share = backwards / backwards.sum()

    def bounded(gap):
        return gaps if gap is None else np.where(backwards, np.clip(gaps, -gap, gap), gaps)

    def fit(gap):
        counted = bounded(gap)

        def objective(w):
            violation = np.maximum(MARGIN - counted - cue_gaps @ w, 0.0)
            gradient = -2 * (share * violation) @ cue_gaps + 2 * PULL * w
            return float(share @ violation ** 2) + PULL * float(w @ w), gradient

        found = minimize(objective, np.zeros(len(CUES)), jac=True, method="L-BFGS-B",
                         bounds=[(0.0, MAX_WEIGHT)] * len(CUES))
        weights = np.clip(found.x, 0.0, MAX_WEIGHT)
        return objective(weights)[0], weights

    fits = [fit(gap) for gap in GAPS]
    best = int(np.argmin([loss for loss, _ in fits]))   # the first (smallest bound) of equal ones
    gap, weights = GAPS[best], fits[best][1]

    def unclear(w, bound):
        return int(len({int(e) for e in examples[backwards & (bounded(bound) + cue_gaps @ w < MARGIN)]}))

    return ({**{key: float(w) for key, w in zip(CUES, weights)}, "head_gap": gap},
            {"weight": round(float(weights[0]), 4), "bulk_weight": round(float(weights[1]), 4),
             "share_weight": round(float(weights[2]), 4), "crest_weight": round(float(weights[3]), 4),
             "toes_weight": round(float(weights[4]), 4), "gap": gap,
             "losses": {str(g): round(loss, 4) for g, (loss, _) in zip(GAPS, fits)},
             "examples": len(own), "unclear_without": unclear(np.zeros(len(CUES)), None),
             "unclear_with": unclear(weights, gap)})
