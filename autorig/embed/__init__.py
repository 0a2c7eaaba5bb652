"""Discrete embedding: the template's reduced skeleton placed on the sphere graph (penalties + A* search)."""
from __future__ import annotations

from ..graph import SphereGraph
from ..template import Template
from .penalties import WEIGHTS, build_problem
from .search import Embedding, search

__all__ = ["embed", "Embedding", "WEIGHTS"]


def embed(graph: SphereGraph, template: Template) -> Embedding:
    """The lowest-penalty placement of ``template.reduced()`` on ``graph``'s spheres."""
    return search(build_problem(graph, template))
