"""How much orientation detection should trust the outline's head/tail cue, learned from the examples.

Detection (``autorig.orient``) ranks candidate frames by embedding penalty plus a prior: the glTF convention's
handicap minus ``head_tail`` times the outline's cue (``orient.head_tail_cue``). For a four-legged template the
embedding facing backwards often costs less than the right one, so front and back are the cue's to tell; for a
biped the embedding tells them apart and the cue (meant for a head on a neck) is noise. The weight is learned
from exactly that: for every example, every frame detection weighs against its own must lose by a margin,

    (cost(F) - w * cue(F)) - (cost(own) - w * cue(own)) >= MARGIN,

where cost is the penalty of the embedding detection would find in that frame (searched long facing backwards,
as detection searches its two best frames). The convention's handicap is
left out: the corpus is in the convention, users' files need not be. ``w`` minimises the mean squared violation
plus a small pull towards 0 (a cue that does not help should not weigh).
"""
from __future__ import annotations

import numpy as np

MARGIN = 1.0       # penalty units a wrong frame must lose by (group cross-validation over the corpus
                   # animals: at 0.5 one of 64 turned animals came out reversed, at 1.0 none)
PULL = 0.01        # pull of w towards 0, per unit of w², against the mean squared violation
MAX_WEIGHT = 5.0   # the cue is clipped to [-1, 1]; beyond this it would outweigh any embedding


def learn_head_tail(settings, cues, template) -> tuple[float, dict]:
    """(w, record) for ``template`` from the examples' ``settings`` (``gamma.Setting``, every frame of every
    example) and the head/tail cue [len(settings)] of each. The record counts the examples whose own frame
    does not win clearly (by MARGIN) without the cue and with it."""
    from scipy.optimize import minimize_scalar

    from ..orient import DECISION_EXPANSIONS, DETECTION_EXPANSIONS, _embedding_cost, _problem
    # Facing backwards is what detection compares on a long search; the other frames it ranks on a short one.
    costs = np.array([_embedding_cost(_problem(s.graph, template), DECISION_EXPANSIONS if s.frame in ("own", "back")
                                      else DETECTION_EXPANSIONS)[0] for s in settings])
    own = {s.example: n for n, s in enumerate(settings) if s.true_frame and np.isfinite(costs[n])}
    gaps, cue_gaps, examples = [], [], []
    for n, s in enumerate(settings):
        if s.true_frame or s.example not in own or not np.isfinite(costs[n]):
            continue
        o = own[s.example]
        gaps.append(costs[n] - costs[o])
        cue_gaps.append(cues[o] - cues[n])
        examples.append(s.example)
    if not gaps:
        return 0.0, {"skipped": "no frames to compare"}
    gaps, cue_gaps, examples = np.array(gaps), np.array(cue_gaps), np.array(examples)
    _, inverse, counts = np.unique(examples, return_inverse=True, return_counts=True)
    share = 1.0 / (counts[inverse] * len(counts))    # every example counts the same, however many frames

    def objective(w):
        return float(share @ np.maximum(MARGIN - gaps - w * cue_gaps, 0.0) ** 2) + PULL * w * w

    weight = float(minimize_scalar(objective, bounds=(0.0, MAX_WEIGHT), method="bounded").x)

    def unclear(w):
        return int(len({int(e) for e in examples[gaps + w * cue_gaps < MARGIN]}))

    return weight, {"weight": round(weight, 4), "examples": len(own),
                    "unclear_without": unclear(0.0), "unclear_with": unclear(weight)}
