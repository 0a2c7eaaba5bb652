"""Which end of a four-legged shape is its head, by the bulk of its limbs' ends: orientation's second cue.

The outline's cue (``orient.head_tail_cue``) reads a head off how far it reaches and how high it is carried,
which a cartoon breaks: a big head sits straight over the front legs (no reach) and a long tail is raised (it
reaches far and ends high). What a head has in every style is bulk: a skull, thick next to its tip, with a
muzzle, ears or horns on it; a tail tapers to a thin end, and an animal without one ends in no limb at all.

The medial spheres' graph ends its limbs at its extremities (``embed.penalties.graph_extremities``: local
maxima of the path distance from the graph's centre that stand out). The four lowest are the feet; the others
are the head's (muzzle, ears, horns) and the tail's. Each is measured by the largest sphere within a third of
the path from its tip to the graph's centre: a skull's radius at the head, a tail's own at the tail. The cue
compares the bulkiest end in front of the feet's middle with the bulkiest behind it. Its weight is the
template's ``head_bulk``, learned with the outline's (``learn/head_tail.py``).

A third cue is where the body's weight lies between the feet (``weight_share_cue``): most four-legged animals
carry more of it on their front legs (a head and neck in front of the shoulders, a thin tail or none behind the
hips), which neither a cartoon's raised tail nor a low animal's thick one turns round. Its weight is the
template's ``head_share``.
"""
from __future__ import annotations

import numpy as np

FEET = 4              # a four-legged shape's lowest limb ends are its feet
END_SHARE = 1 / 3     # the part of the path from a limb's tip to the graph's centre whose bulk is the end's
FEET_BAND = 0.08      # the lowest part of the shape (fraction of its height) taken as where its feet are


def end_bulk_cue(graph, vertices: np.ndarray) -> float:
    """How surely a shape faces +z rather than -z by its limbs' ends, in [-1, 1] (positive: the head is at +z):
    (bulk in front - bulk behind) / the larger of the two, each the radius of the bulkiest end on that side of
    the feet's middle (0 where there is none: an animal without a tail scores 1). Turning the shape round
    negates it.

    graph: the sphere graph (centers [S, 3], radii [S], distances [S, S]) in a candidate frame (+y up, front
    along z); vertices [V, 3] the surface's vertices in that frame."""
    from .penalties import PROMINENCE, prominences
    prominence = prominences(graph)
    tips = np.flatnonzero(prominence >= PROMINENCE)
    if len(tips) <= FEET:
        return 0.0
    tips = tips[np.argsort(graph.centers[tips, 1], kind="stable")][FEET:]
    y, z = vertices[:, 1], vertices[:, 2]
    feet = z[y <= y.min() + FEET_BAND * np.ptp(y)]
    middle = (feet.min() + feet.max()) / 2
    centre = int(np.argmin(graph.distances.max(axis=1)))
    bulk = {True: 0.0, False: 0.0}
    for tip in tips:
        # A limb's length is how far its tip stands out (its prominence), a bump on the rump's only the bump's:
        # so the part measured is the limb's own, never the body it leaves.
        length = min(float(prominence[tip]), float(graph.distances[tip, centre]))
        if not np.isfinite(length):
            continue
        near = graph.distances[tip] <= END_SHARE * length
        side = bool(graph.centers[tip, 2] >= middle)
        bulk[side] = max(bulk[side], float(graph.radii[near].max()))
    larger = max(bulk.values())
    return (bulk[True] - bulk[False]) / larger if larger > 0 else 0.0


def weight_share_cue(graph, vertices: np.ndarray) -> float:
    """How surely a shape faces +z rather than -z by where its volume lies between its feet, in [-1, 1]
    (positive: the head is at +z): the medial spheres' volume-weighted (radius cubed) centre along z, minus the
    feet's middle, over half the feet's spread along z (-1 over the back feet, +1 over the front ones), clipped.
    Turning the shape round negates it.

    graph: the sphere graph (centers [S, 3], radii [S]) in a candidate frame (+y up, front along z); vertices
    [V, 3] the surface's vertices in that frame."""
    y, z = vertices[:, 1], vertices[:, 2]
    feet = z[y <= y.min() + FEET_BAND * np.ptp(y)]
    half = (feet.max() - feet.min()) / 2
    volume = graph.radii ** 3
    if half <= 0 or volume.sum() <= 0:
        return 0.0
    centre = float(volume @ graph.centers[:, 2] / volume.sum())
    return float(np.clip((centre - (feet.min() + feet.max()) / 2) / half, -1.0, 1.0))
