"""The spine of autorig: one line per stage of Baran & Popović's method.

    mesh       -> prepare         canonical frame (+y up, facing +z, one unit tall), private working copy
               -> distance_field  adaptive octree of signed distance, winding-number inside/outside
               -> medial_samples  creases of the distance field: the approximate medial surface
               -> pack_spheres    maximal inscribed spheres, largest first
               -> sphere_graph    spheres joined through the interior
               -> embed           A* over placements of the template's reduced skeleton
               -> place_on_paths  every template joint along the embedded paths
               -> refine          continuous optimisation of all joints
               -> bone_heat       skin weights for every input vertex
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .result import Rig


@dataclass
class RigOptions:
    """up, front: which input axis points up and which way the character faces (x|y|z|-x|-y|-z)."""
    up: str = "y"
    front: str = "z"


def rig(mesh, template="biped", options: RigOptions | None = None) -> Rig:
    """Rig a mesh with a template skeleton.

    mesh: a path (OBJ, PLY, STL, OFF, glTF/GLB) or a pair (vertices [V, 3], faces [F, 3]).
    template: a built-in template name, a path to a template JSON file, or a ``Template``.
    Returns a ``Rig`` in the input's own coordinates, weights for every input vertex in input order.
    """
    from .attach import bone_heat
    from .distance import distance_field
    from .embed import embed
    from .graph import sphere_graph
    from .medial import medial_samples, pack_spheres
    from .mesh import load_mesh, prepare
    from .refine import place_on_paths, refine
    from .template import Template, load_template

    options = options or RigOptions()
    timings: dict[str, float] = {}
    stage = _stage_timer(timings)

    with stage("load"):
        vertices, faces = load_mesh(mesh) if isinstance(mesh, (str, Path)) else _as_arrays(mesh)
        template = template if isinstance(template, Template) else load_template(template)
        prepared = prepare(vertices, faces, up=options.up, front=options.front)
    with stage("distance field"):
        field = distance_field(prepared.work_vertices, prepared.work_faces)
    with stage("medial spheres"):
        spheres = pack_spheres(medial_samples(field))
    with stage("sphere graph"):
        graph = sphere_graph(field, spheres)
    with stage("embedding"):
        embedding = embed(graph, template)
    with stage("refinement"):
        joints = refine(field, place_on_paths(graph, embedding, template), template)
    with stage("skin weights"):
        weights = bone_heat(prepared.vertices, prepared.faces, joints, template.parents)

    return Rig(
        names=list(template.names), parents=template.parents.copy(), joints=prepared.from_canonical(joints),
        weights=weights, vertices=vertices, faces=faces, template=template.name, timings=timings,
        info={"up": options.up, "front": options.front, "embedding_penalty": round(float(embedding.cost), 4),
              "spheres": int(len(graph.radii)), "search_expansions": int(embedding.expanded)})


def _as_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    vertices, faces = mesh
    return np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)


def _stage_timer(timings: dict[str, float]):
    @contextmanager
    def stage(name: str):
        start = time.perf_counter()
        yield
        timings[name] = time.perf_counter() - start
    return stage
