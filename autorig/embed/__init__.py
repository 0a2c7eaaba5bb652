"""Discrete embedding: the template's reduced skeleton placed on the sphere graph (penalties + A* search)."""
from __future__ import annotations

from ..discretize.graph import SphereGraph
from ..template import Template
from .penalties import WEIGHTS, build_problem
from .search import MAX_EXPANSIONS, Embedding, search

__all__ = ["embed", "Embedding", "WEIGHTS"]


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
