"""Which end of a four-legged shape is its head, by its limbs' ends and its feet: orientation's cues.

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

All of these read the head and tail, which an animal carries as it likes: with its head low (grazing, or walking
with its head down) the outline, the crest and the bulk read the withers or a curled tail as the head (0 A.D.'s
wolf: all four cues -0.29 to +0.04). The feet are carried the same way in every pose: a paw's toes, a hoof's
wall and a plantigrade foot's sole reach forward of the leg above it, and its heel not as far back
(``toes_cue``). Its weight is the template's ``head_toes``.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

FEET = 4              # a four-legged shape's lowest limb ends are its feet
END_SHARE = 1 / 3     # the part of the path from a limb's tip to the graph's centre whose bulk is the end's
FEET_BAND = 0.08      # the lowest part of the shape (fraction of its height) taken as where its feet are
# ``toes_cue``, in heights (the shape's height along y): a foot's sole is its surface within TOE_SOLE of its lowest
# point and within TOE_REACH across (or half-way to the nearest other foot), its leg's axis the medial spheres
# of its path read TOE_AXIS_AT above that point; the leg's tilt is fitted to those spheres TOE_AXIS above the
# foot's own; a foot lies at least TOE_OFF_PLANE off the mid-plane (a lowered snout on the ground does not); the
# surface is sampled TOE_STEP apart up to TOE_LOW; a median reach of TOE_SCALE scores 1. Measured by hand on the 31
# animals of benchmarks/animals.py, the median foot reaches forward by 0.026 (0 A.D.'s goat) to 0.21 heights
# standing, by 0.011 or more with the head low, and walking all but OpenClonk's puka's (-0.049; measured from the
# leg's surface just above the foot, untilted, six walking animals' read backward: the bears, the hippopotamus,
# the rhino, the tiger, the Quaternius wolf).
TOE_SOLE = 0.025
TOE_AXIS_AT = 0.08
TOE_REACH = 0.1
TOE_AXIS = (0.08, 0.30)
TOE_OFF_PLANE = 0.02
TOE_STEP = 0.01
TOE_LOW = 0.25
TOE_SCALE = 0.02


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


def toes_cue(graph, vertices: np.ndarray, faces: np.ndarray) -> float:
    """How surely a four-legged shape faces +z rather than -z by its feet, in [-1, 1] (positive: its toes point to
    +z): the median over its feet of how much farther the sole reaches forward of its leg's axis than backward
    (the medial spheres of the foot's path from the graph's centre, read just above the foot), over
    ``TOE_SCALE`` heights, clipped (0 without two feet on each side of the mid-plane). Turning the shape round
    negates it.

    The feet are the two lowest limb ends (``penalties.prominences``) on each side of the mid-plane (x half-way
    across the box), off it by ``TOE_OFF_PLANE``. A leg swung forward or back tilts its foot with it (a walk's
    legs by 20-25 degrees, against a toe's reach of a few hundredths of the height); each foot is measured
    turned back by its leg's tilt beyond its pair's (the front feet's, the hind feet's) mean tilt, the tilt
    fitted to the leg's medial spheres ``TOE_AXIS`` above it: a walk's pairs swing opposite ways, while a
    standing animal's legs slope as they are built (0 A.D.'s wolf's forelegs 18 degrees, both alike) and stay
    as they are.

    graph: the sphere graph in a candidate frame (+y up, front along z); vertices [V, 3], faces [F, 3] the
    surface in that frame."""
    from .penalties import PROMINENCE, prominences
    height = float(np.ptp(vertices[:, 1]))
    if height <= 0:
        return 0.0
    tips = np.flatnonzero(prominences(graph) >= PROMINENCE)
    tips = tips[np.argsort(graph.centers[tips, 1], kind="stable")]
    off = graph.centers[tips, 0] - (vertices[:, 0].min() + vertices[:, 0].max()) / 2
    sides = [tips[off >= TOE_OFF_PLANE * height][:2], tips[off <= -TOE_OFF_PLANE * height][:2]]
    if min(len(side) for side in sides) < 2:
        return 0.0
    # [front left, hind left, front right, hind right]: each side's two feet by z
    feet = np.array([t for side in sides for t in side[np.argsort(-graph.centers[side, 2], kind="stable")]])
    centre = int(np.argmin(graph.distances.max(axis=1)))     # as ``prominences``: every tip is reachable from it
    tilt = np.array([_leg_tilt(graph, centre, int(f), height) for f in feet])
    tilt -= (tilt + tilt[[2, 3, 0, 1]]) / 2              # beyond the pair's mean (front with front, hind with hind)
    points = _surface_samples(vertices, faces, height)
    reach = [_toe_reach(points, graph.centers[f], np.delete(graph.centers[feet], k, axis=0),
                        graph.centers[graph.path(centre, int(f))], t, height)
             for k, (f, t) in enumerate(zip(feet, tilt))]
    reach = [r for r in reach if r is not None]
    return float(np.clip(np.median(reach) / TOE_SCALE, -1.0, 1.0)) if reach else 0.0


def _leg_tilt(graph, centre: int, foot: int, height: float) -> float:
    """The angle (radians) from +y toward +z of the leg above ``foot``: the line fitted to the medial spheres of
    its path from ``centre`` between ``TOE_AXIS`` heights above it (0 with fewer than two)."""
    c = graph.centers[graph.path(centre, foot)]
    rise = c[:, 1] - graph.centers[foot, 1]
    c = c[(rise >= TOE_AXIS[0] * height) & (rise <= TOE_AXIS[1] * height)]
    if len(c) < 2 or np.ptp(c[:, 1]) <= 1e-12:
        return 0.0
    return float(np.arctan(np.polyfit(c[:, 1], c[:, 2], 1)[0]))


def _toe_reach(points: np.ndarray, foot: np.ndarray, others: np.ndarray, leg: np.ndarray, tilt: float,
               height: float) -> float | None:
    """How much farther (heights) the sole around ``foot`` (its sphere's centre) reaches forward of its leg's
    medial axis ``leg`` [P, 3] (the spheres of its path) than backward, in the foot's frame turned back by
    ``tilt``, the axis read ``TOE_AXIS_AT`` above the sole; None where there is no sole or the axis does not
    reach that high. others [3, 3]: the other feet (the sole's neighbourhood stops half-way to the nearest)."""
    c, s = np.cos(tilt), np.sin(tilt)

    def turned(p):
        q = p - foot
        return q[:, 0], c * q[:, 1] + s * q[:, 2], c * q[:, 2] - s * q[:, 1]
    across = min(0.5 * float(np.min(np.linalg.norm(others[:, [0, 2]] - foot[[0, 2]], axis=1))), TOE_REACH * height)
    points = points[np.linalg.norm(points - foot, axis=1) <= np.hypot(across, TOE_LOW * height)]
    x, y, z = turned(points)
    near = (np.hypot(x, z) <= across) & (y <= TOE_LOW * height)
    y, z = y[near], z[near]
    if len(y) == 0:
        return None
    low = float(y.min())
    sole = z[y <= low + TOE_SOLE * height]
    _, ly, lz = turned(leg)
    at = low + TOE_AXIS_AT * height
    if len(sole) < 3 or not ly.min() <= at <= ly.max():
        return None
    order = np.argsort(ly, kind="stable")
    axis = float(np.interp(at, ly[order], lz[order]))
    return ((sole.max() - axis) - (axis - sole.min())) / height


def _surface_samples(vertices: np.ndarray, faces: np.ndarray, height: float) -> np.ndarray:
    """[N, 3] points on the faces that reach within ``TOE_LOW`` of the bottom: each face cut into k x k
    triangles at most ``TOE_STEP`` across (k at most 20), their centroids; the same set in any face order."""
    corners = vertices[faces]
    corners = corners[corners[:, :, 1].min(axis=1) <= vertices[:, 1].min() + TOE_LOW * height]
    longest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    cuts = np.clip(np.ceil(longest / (TOE_STEP * height)).astype(int), 1, 20)
    out = [np.zeros((0, 3))]
    for k in np.unique(cuts):
        tri = corners[cuts == k]
        a, b = _centroids(int(k))
        out.append(((1 - a - b)[None, :, None] * tri[:, None, 0] + a[None, :, None] * tri[:, None, 1]
                    + b[None, :, None] * tri[:, None, 2]).reshape(-1, 3))
    return np.concatenate(out)


@lru_cache(maxsize=None)
def _centroids(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The barycentric coordinates (of the second and third corner) of the centroids of a triangle's k x k
    subdivision."""
    up = [((i + 1 / 3) / k, (j + 1 / 3) / k) for i in range(k) for j in range(k - i)]
    down = [((i + 2 / 3) / k, (j + 2 / 3) / k) for i in range(k) for j in range(k - i - 1)]
    a, b = np.array(up + down).T
    return a, b
