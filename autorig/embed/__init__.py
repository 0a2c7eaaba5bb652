"""Discrete embedding: the template's reduced skeleton placed on the sphere graph (penalties + A* search)."""
from __future__ import annotations

from ..discretize.graph import SphereGraph
from ..template import Template
from .penalties import WEIGHTS, build_problem
from .search import MAX_EXPANSIONS, Embedding, _paths, search

__all__ = ["embed", "Embedding", "WEIGHTS", "swap_mirrored"]


def embed(graph: SphereGraph, template: Template, max_expansions: int | None = None, held=None) -> Embedding:
    """The lowest-penalty placement of ``template.reduced()`` on ``graph``'s spheres; past ``max_expansions`` A*
    expansions (None: ``search.MAX_EXPANSIONS``) the search finishes greedily. ``held``: the joints the user
    marked (``autorig.markers.Held``, the graph's frame), kept near their markers by a penalty."""
    problem = build_problem(graph, template, held)
    found = search(problem, MAX_EXPANSIONS if max_expansions is None else max_expansions)
    if held is not None:
        # The cost the confidence judges is the skeleton's fit to the shape, without the markers' penalty.
        from .penalties import embedding_terms
        found.cost = float(sum(problem.weights[p] * v for p, v in embedding_terms(problem, found.spheres).items()))
        found.bound = min(float(found.bound), found.cost)
    return found


def swap_mirrored(graph: SphereGraph, template: Template, embedding: Embedding, joints: list[int]) -> Embedding:
    """``embedding`` with each reduced joint whose chain holds one of the template ``joints`` (and its subtree)
    on its mirror image's sphere and the mirror image on its: the two limbs' ends given to each other (a left
    arm's chain that ran through the right arm, and the right's through the left). Paths and cost (without the
    markers' penalty) are those of the swapped placement; the search's bound is kept."""
    import numpy as np

    from .penalties import embedding_terms
    problem = build_problem(graph, template)
    reduced = problem.reduced
    parents, order = reduced.parents, [int(j) for j in reduced.joints]
    chain_of = {}
    for k in range(1, len(order)):
        t = order[k]
        while t >= 0 and t != order[parents[k]]:
            chain_of[t] = k
            t = int(template.parents[t])
    original = np.asarray(embedding.spheres)
    spheres = original.copy()
    moved = set()
    for joint in joints:
        k = chain_of.get(int(joint))
        if k is None or problem.mirror[k] < 0 or k in moved:
            continue
        subtree = [c for c in range(len(order)) if _descends(parents, c, k)]
        for c in subtree:
            m = int(problem.mirror[c])
            if m >= 0 and c not in moved:
                spheres[[c, m]] = original[[m, c]]
                moved.update((c, m))
    if not moved:
        return embedding
    paths = _paths(problem, tuple(int(s) for s in spheres))
    cost = float(sum(problem.weights[p] * v for p, v in embedding_terms(problem, spheres).items()))
    return Embedding(spheres=spheres, paths=paths, cost=cost, expanded=embedding.expanded,
                     optimal=embedding.optimal, bound=min(float(embedding.bound), cost),
                     swapped=tuple(sorted(moved)))


def _descends(parents, c: int, k: int) -> bool:
    while c >= 0:
        if c == k:
            return True
        c = int(parents[c])
    return False
