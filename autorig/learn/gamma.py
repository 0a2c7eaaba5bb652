"""The embedding's penalty weights Γ, learned by max margin as Baran & Popović learned theirs.

For each example the *true embedding* is the best placement of the reduced skeleton close to the example's own
skeleton (each reduced joint within ``NEAR`` of the nearest sphere it may occupy; found by the search under the
current Γ, so it changes from round to round as in a latent structural SVM). Γ must make it cost less, by a margin that
grows with how wrong the other embedding is, than the embeddings the search finds instead, in the example's
own frame and in the frames that face the wrong way (which is what orientation detection compares). With
b(E) the vector of unweighted penalties of an embedding (``embed.penalties.embedding_terms``)::

    Γ · (b(E) - b(E*)) >= loss(E, E*) - (handicap(E's frame) - handicap(E*'s frame))

The loop is the usual cutting-plane one: search with the current Γ, add the constraints it violates, solve
again. Each solve minimises the mean squared violation plus a pull towards the hand-set weights (the corpus
is small; Γ should move only where the examples say so), with Γ >= 0, by ``scipy.optimize`` (L-BFGS-B).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..embed.penalties import WEIGHTS, build_problem, embedding_terms
from ..embed.search import search
from ..errors import RigFailedError

LOSS_UNIT = 0.2        # template units: a mean joint displacement this large is one full unit of loss
LOSS_CAP = 1.0         # embeddings wronger than that are all equally wrong
PRIOR = 0.1            # pull towards the hand-set weights, relative to the mean squared violation
ROUNDS = 4
SEARCH_BUDGET = 1500   # A* expansions per search while learning (the greedy embedding past it)
MIN_WEIGHT = 1e-3      # no penalty is switched off entirely
NEAR = 0.04            # template units: how far from the nearest sphere a true embedding's joints may sit


@dataclass
class Setting:
    """One example as the learner embeds it, in one frame.

    graph      the sphere graph in that frame
    truth      [K, 3] the example's reduced joints in that frame
    handicap   the orientation handicap of that frame (``autorig.embed.orient``)
    example    index of the example
    field      the distance field in that frame (the calibration refines rigs in it)
    frame      "own", "back" (facing backwards, the same up) or "other"
    extent     [3] the mesh's bounding box in that frame
    """
    graph: object
    truth: np.ndarray
    handicap: float
    example: int
    field: object
    frame: str
    extent: np.ndarray

    @property
    def true_frame(self) -> bool:
        """Whether this is the example's own frame."""
        return self.frame == "own"


@dataclass
class Constraint:
    difference: np.ndarray   # [P] b(E) - b(E*)
    loss: float              # required margin, handicaps included
    example: int


@dataclass
class GammaReport:
    weights: dict
    rounds: list = field(default_factory=list)    # per round: constraints, violated, mean loss of the search


def near_truth(problem, truth: np.ndarray, reach: float = NEAR):
    """A copy of ``problem`` in which every reduced joint may only take the spheres within ``reach`` of the
    nearest one it may occupy to its true position [K, 3]: the search in it finds the best embedding that is
    close to the example's own skeleton (its *true embedding* under the current Γ)."""
    from copy import copy
    C = problem.graph.centers
    near = []
    for k in range(len(truth)):
        d = np.linalg.norm(C[problem.candidates[k]] - truth[k], axis=1)
        near.append(d <= d.min() + reach)
    out = copy(problem)
    out.root_cost = problem.root_cost.copy()
    far_roots = problem.candidates[0][~near[0]]
    out.root_cost[far_roots] = np.inf
    out.bone_cost = [None] + [np.where(near[k][None, :], problem.bone_cost[k], np.inf)
                              for k in range(1, len(truth))]
    return out


def embedding_loss(centers: np.ndarray, spheres: np.ndarray, truth: np.ndarray) -> float:
    """How wrong an embedding is: the mean distance of its reduced joints from the truth [K, 3], per
    LOSS_UNIT, capped at LOSS_CAP."""
    return float(min(np.mean(np.linalg.norm(centers[spheres] - truth, axis=1)) / LOSS_UNIT, LOSS_CAP))


def learn_weights(settings: list[Setting], template, rounds: int = ROUNDS, progress=None) -> GammaReport:
    """Γ for ``template`` from the examples' ``settings`` (see the module docstring)."""
    from dataclasses import replace
    names = list(WEIGHTS)
    prior = np.array([WEIGHTS[n] for n in names])
    gamma = np.array([(template.penalty_weights or WEIGHTS)[n] for n in names])
    base_handicap = {s.example: s.handicap for s in settings if s.true_frame}
    alternatives: list[tuple[np.ndarray, float, int]] = []    # (penalties of an embedding found, margin, example)
    report = GammaReport(weights={})
    for r in range(rounds):
        current = replace(template, penalty_weights=dict(zip(names, gamma)))
        violated, losses = 0, []
        problems = [_problem(s.graph, current) for s in settings]
        # The true embeddings under the current Γ (the best placements near each example's own skeleton).
        truths = {}
        for s, problem in zip(settings, problems):
            if not s.true_frame or problem is None:
                continue
            try:
                best = search(near_truth(problem, s.truth), max_expansions=SEARCH_BUDGET)
            except RigFailedError:
                continue
            truths[s.example] = _vector(embedding_terms(problem, best.spheres), names)
        for s, problem in zip(settings, problems):
            if s.example not in truths or problem is None:
                continue
            try:
                found = search(problem, max_expansions=SEARCH_BUDGET if s.true_frame else SEARCH_BUDGET // 5)
            except RigFailedError:
                continue
            terms = _vector(embedding_terms(problem, found.spheres), names)
            loss = embedding_loss(s.graph.centers, found.spheres, s.truth)
            margin = loss - (s.handicap - base_handicap[s.example])
            if s.true_frame:
                losses.append(loss)
            if margin > 1e-9:
                violated += float(gamma @ (terms - truths[s.example])) < margin
                alternatives.append((terms, margin, s.example))
        # Every embedding found so far, against this round's true embeddings.
        constraints = [Constraint(terms - truths[n], margin, n) for terms, margin, n in alternatives if n in truths]
        report.rounds.append({"constraints": len(constraints), "violated": int(violated),
                              "mean_loss": round(float(np.mean(losses)), 4) if losses else None})
        if progress:
            progress(f"penalty weights, round {r + 1}/{rounds}: {violated} violated constraints, "
                     f"mean embedding loss {report.rounds[-1]['mean_loss']}")
        if not constraints:
            break
        gamma = _solve(constraints, prior, gamma)
    report.weights = {n: float(g) for n, g in zip(names, gamma)}
    return report


def _solve(constraints: list[Constraint], prior: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Γ >= MIN_WEIGHT minimising the mean (per example) squared violation plus PRIOR * |Γ - prior|² / |prior|²."""
    from scipy.optimize import minimize
    A = np.array([c.difference for c in constraints])
    b = np.array([c.loss for c in constraints])
    examples = np.array([c.example for c in constraints])
    _, inverse, counts = np.unique(examples, return_inverse=True, return_counts=True)
    share = 1.0 / (counts[inverse] * len(counts))
    norm = float(prior @ prior)

    def objective(g):
        slack = np.maximum(b - A @ g, 0.0)
        value = float(share @ slack ** 2) + PRIOR * float((g - prior) @ (g - prior)) / norm
        grad = -2.0 * (share * slack) @ A + 2.0 * PRIOR * (g - prior) / norm
        return value, grad

    result = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=[(MIN_WEIGHT, None)] * len(prior))
    return result.x


def _problem(graph, template):
    try:
        return build_problem(graph, template)
    except RigFailedError:
        return None


def _vector(terms: dict, names: list[str]) -> np.ndarray:
    return np.array([terms[n] for n in names])
