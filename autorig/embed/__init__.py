"""Discrete embedding: the template's reduced skeleton placed on the sphere graph (penalties + A* search)."""
from __future__ import annotations

from ..discretize.graph import SphereGraph
from ..template import Template
from .penalties import WEIGHTS, build_problem
from .search import MAX_EXPANSIONS, Embedding, search

__all__ = ["embed", "Embedding", "WEIGHTS"]


def embed(graph: SphereGraph, template: Template, max_expansions: int | None = None) -> Embedding:
    """The lowest-penalty placement of ``template.reduced()`` on ``graph``'s spheres; past ``max_expansions`` A*
    expansions (None: ``search.MAX_EXPANSIONS``) the search finishes greedily."""
    return search(build_problem(graph, template), MAX_EXPANSIONS if max_expansions is None else max_expansions)
