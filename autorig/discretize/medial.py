"""Approximate medial surface and the packing of maximal inscribed spheres (the discretization's second half).

The medial surface is where the distance field has a crease: a point there is equally far from two different
parts of the surface. The octree stores, at every cell corner, the nearest surface point; along a cell edge
whose two inside corners look at surface points in clearly different directions, the medial surface crosses
the edge where the point is equally far from both surface points (the bisector plane of the two). Each such
crossing is a medial sample, and its distance to the surface is the radius of a maximal inscribed sphere.

Spheres are then packed greedily, largest first, keeping a sphere only if its centre lies in no sphere kept
before. Few large spheres fill the torso, chains of small ones fill the limbs: the graph built on them is
small but still follows every limb.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..input.facing import unique_ints
from .distance import CORNERS, DistanceField, grid_index, grid_number

# Pairs of CORNERS indices that differ along exactly one axis: the 12 edges of a cell.
EDGES = np.array([(a, b) for a in range(8) for b in range(a + 1, 8)
                  if np.abs(CORNERS[a] - CORNERS[b]).sum() == 1])
EDGE_AXIS = np.argmax(CORNERS[EDGES[:, 1]] - CORNERS[EDGES[:, 0]], axis=1)   # [12] the axis each edge runs along


@dataclass
class MedialSamples:
    """points [M, 3] on the approximate medial surface; radii [M] their distance to the surface."""
    points: np.ndarray
    radii: np.ndarray


@dataclass
class Spheres:
    """Packed maximal inscribed spheres, largest first: centers [S, 3], radii [S]."""
    centers: np.ndarray
    radii: np.ndarray


def medial_samples(field: DistanceField, min_angle_degrees: float = 70.0) -> MedialSamples:
    """Medial-surface crossings on the edges of the octree's leaf cells.

    min_angle_degrees: how far apart the two nearest-point directions must turn for an edge to count as
    crossing the medial surface; small angles come from surface noise (bumps make tiny medial branches).
    """
    # Only edges with both ends inside can cross the medial surface; the leaves know their corners' depths.
    inside_corner = field.leaf_values > 0                                            # [C, 8]
    leaf, edge = np.nonzero(inside_corner[:, EDGES[:, 0]] & inside_corner[:, EDGES[:, 1]])
    # Neighbouring leaves of one size share edges: count each once. An edge is its first corner's number on the
    # finest grid, its axis and its length (its leaf's level), packed into one integer. Gathered per edge as
    # such 1-D numbers rather than [N, 3] rows: the edges number ~300k at 20k faces.
    leaf_level = field.leaf_level[leaf]
    edge_len = 2 ** (field.max_level - field.leaf_level)                            # [C]
    first_corner = grid_number(field.leaf_index, field.max_level)                    # [C]
    step = grid_number(CORNERS[EDGES[:, 0]], field.max_level)                        # [12] from the leaf's corner
    a_number = first_corner[leaf] + step[edge] * edge_len[leaf]
    edge_key = (a_number * 3 + EDGE_AXIS[edge]) * (field.max_level + 1) + leaf_level
    # The key holds all an edge needs: each once, in the key's order, read back out of it (a plain sort: the
    # first of each key's edges, np.unique's return_index, took a stable sort twice as long).
    edge_key = unique_ints(edge_key)
    level = edge_key % (field.max_level + 1)
    a_number, axis = edge_key // (field.max_level + 1) // 3, (edge_key // (field.max_level + 1) % 3).astype(
        EDGE_AXIS.dtype)
    length = 2 ** (field.max_level - level)
    a_idx = grid_index(a_number, field.max_level)
    b_idx = a_idx.copy()
    b_idx[np.arange(len(b_idx)), axis] += length
    ia, ib = field.corner_row[a_number], field.corner_rows(b_idx)
    da, db = field.corner_depth[ia], field.corner_depth[ib]
    a = field.origin + a_idx * field.finest
    b = field.origin + b_idx * field.finest
    ca, cb = field.corner_nearest[ia], field.corner_nearest[ib]
    cos_turn = np.cos(np.radians(min_angle_degrees))
    sides = list(_plane_sides(field, a_idx, axis))
    # The ends on a centre plane, which are read off it: a few percent of the edges' ends.
    centre = 2 ** (field.max_level - 1)
    on_plane = {end: np.any(idx == centre, axis=1) for idx, end in ((a_idx, -1.0), (b_idx, 1.0))}
    nudged = _NudgedNearest(field, [_nudges(field, idx[moved], axis[moved], end, signs)
                                    for signs, rows in sides for idx, end in ((a_idx, -1.0), (b_idx, 1.0))
                                    for moved in [rows[on_plane[end][rows]]]])
    points, radii = [], []
    for signs, rows in sides:
        part = (lambda x: x) if len(rows) == len(axis) else (lambda x: x[rows])   # every edge: no copies
        sa, sb = _off_the_centre_planes(field, part(a_idx), part(b_idx), part(axis), part(a), part(b),
                                        part(ca), part(cb), signs, nudged)
        p, r = _crossings(part(a), part(b), sa, sb, part(da), part(db), cos_turn)
        points.append(p)
        radii.append(r)
    return MedialSamples(points=np.concatenate(points), radii=np.concatenate(radii))


def _crossings(a, b, ca, cb, da, db, cos_turn):
    """Where the edges a-b cross the medial surface of the nearest points ca, cb: (points, radii)."""
    ga = (a - ca) / da[:, None]
    gb = (b - cb) / db[:, None]
    turned = np.einsum("ij,ij->i", ga, gb) < cos_turn
    a, b, ca, cb = a[turned], b[turned], ca[turned], cb[turned]
    # Point x = a + t (b - a) equally far from ca and cb: 2 x.(cb - ca) = |cb|^2 - |ca|^2.
    n = cb - ca
    denom = np.einsum("ij,ij->i", b - a, n)
    rhs = 0.5 * (np.einsum("ij,ij->i", cb, cb) - np.einsum("ij,ij->i", ca, ca)) - np.einsum("ij,ij->i", a, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = rhs / denom
    ok = np.isfinite(t) & (t >= 0) & (t <= 1)
    points = a[ok] + t[ok, None] * (b[ok] - a[ok])
    radii = np.linalg.norm(points - ca[ok], axis=1)
    return points, radii


def pack_spheres(samples: MedialSamples, min_radius: float = 0.0, rotation: np.ndarray | None = None) -> Spheres:
    """Greedy packing: visit samples by decreasing radius; keep one if no kept sphere contains its centre.

    rotation: [3, 3] from the samples' frame to the character's own (x left, y up, z front), when known:
    samples equal in radius and in distance from the middle (a symmetric body's mirror pairs) are visited in
    the order of their coordinates in that frame, the same however the mesh was turned in its file.

    min_radius: ignore samples thinner than this (in height units). The rig passes the field's finest cell
    edge: a thinner sphere sits in a crease the field cannot resolve, most often a bump of a scanned surface.
    Such spheres carry no limb the template could use, yet each is a node the graph, the orientation and the
    search must consider (armadillo at 20k faces: 560 spheres -> 348, A* expansions 810 -> 88).
    """
    from scipy.spatial import cKDTree

    keep_mask = samples.radii > min_radius
    if not keep_mask.any():
        from ..errors import RigFailedError
        raise RigFailedError("the mesh encloses no volume that a skeleton could sit in (is it an open sheet, "
                             "or much thinner than it is wide?)")
    points, radii = samples.points[keep_mask], samples.radii[keep_mask]
    # Largest first, but radii within RADIUS_STEP of each other count as equal and go innermost first. Samples
    # often tie on their radius (all along a prism-shaped limb of a low-poly mesh), and which of them is
    # visited first decides which are kept, and through what each covers, the whole packing: by coordinates,
    # a rounding error's worth of noise reorders them (a 256-triangle figure's 141 of 535 spheres moved). By
    # distance from the middle of the samples' box the order is the same for the mesh turned or re-exported.
    # That distance is binned like the radius: mirror twins tie on it, and compared to the last bit it was the
    # noise's to decide which twin the packing took (a Spartan's hips 4.2 % of the height, a rabbit's and a
    # fox's elbows); binned, the character's own frame decides.
    middle = (points.min(axis=0) + points.max(axis=0)) / 2
    inward = np.sort((points - middle) ** 2, axis=1).sum(axis=1)   # summed in an order the axes' cannot change
    own = points if rotation is None else points @ np.asarray(rotation, dtype=np.float64).T
    order = np.lexsort((own[:, 2], own[:, 1], own[:, 0], np.floor(np.sqrt(inward) / RADIUS_STEP),
                        -np.floor(radii / RADIUS_STEP)))
    points, radii = points[order], radii[order]
    tree = cKDTree(points)
    covered = np.zeros(len(points), dtype=bool)
    kept = []
    for i in range(len(points)):
        if covered[i]:
            continue
        kept.append(i)
        covered[tree.query_ball_point(points[i], radii[i])] = True
    kept = np.array(kept, dtype=np.int64)
    return Spheres(centers=points[kept], radii=radii[kept])


RADIUS_STEP = 1e-4   # heights: medial radii this close are visited as equal (``pack_spheres``)
NUDGE = 0.05   # of the finest cell: how far off a centre-plane corner its edge's nearest point is read


def _plane_sides(field: DistanceField, a_idx, axis):
    """(signs [3], rows) pairs: from which side (-1 or +1 along each axis) the edges ``rows`` read the centre
    planes they lie in. Every edge reads from the lower sides; an edge lying in a centre plane reads from its
    upper side too (in each combination, for an edge in two planes), so that the samples are the same whichever
    way the body is turned or mirrored in the octree.
    """
    centre = 2 ** (field.max_level - 1)
    in_plane = a_idx == centre                                  # [E, 3]; b differs from a along its axis only
    in_plane[np.arange(len(axis)), axis] = False
    for code in range(8):
        signs = np.array([1.0 if code >> k & 1 else -1.0 for k in range(3)])
        upper = signs > 0
        # The edges for which this combination differs from the all-lower one on every upper axis.
        rows = np.flatnonzero(np.all(in_plane[:, upper], axis=1)) if code else np.arange(len(axis))
        if len(rows):
            yield signs, rows


def _off_the_centre_planes(field: DistanceField, a_idx, b_idx, axis, a, b, ca, cb, signs=(-1.0, -1.0, -1.0),
                           nudged: "_NudgedNearest | None" = None):
    """(ca, cb) with the nearest surface point of each edge end that lies on one of the octree's three centre
    planes read a little off the plane instead (``NUDGE`` of the finest cell): beyond the edge's end for the
    plane across the edge, to the side ``signs`` gives (per axis) for a plane the edge lies in.

    A mirror-symmetric body's mid-plane is the octree's centre plane (the cube is centred on the body's box),
    so every corner on it is equally far from the left and the right side: which of the two its stored nearest
    point lies on is a tie that the smallest change of the mesh flips (a 0 A.D. rhino's 814 mid-plane corners
    under 1e-6 noise), and with it whether the edges at it cross the medial surface, the samples there and the
    spheres packed from them. Read from beyond the end, an edge across the plane sees the crease at the plane
    whatever the tie; an edge in the plane is read from each side in turn (``_plane_sides``), so that turning
    or mirroring the body, which swaps the sides, gives the same samples.

    nudged: the nearest points of the nudged ends, asked for already (``_NudgedNearest``); None: asked here.
    """
    centre = 2 ** (field.max_level - 1)
    out = []
    for idx, nearest, end in ((a_idx, ca, -1.0), (b_idx, cb, 1.0)):
        moved = np.flatnonzero(np.any(idx == centre, axis=1))     # the ends with a nudge
        nearest = nearest.copy()
        if len(moved):
            numbers, nudge = _nudges(field, idx[moved], axis[moved], end, signs)
            nearest[moved] = (nudged or _NudgedNearest(field, [(numbers, nudge)])).nearest(numbers, nudge)
        out.append(nearest)
    return out[0], out[1]


def _nudges(field: DistanceField, idx, axis, end: float, signs) -> tuple[np.ndarray, np.ndarray]:
    """(grid numbers [E], nudges [E, 3] in {-1, 0, 1}) of one end of each edge (integer corners ``idx`` [E, 3],
    edges along ``axis`` [E]; ``end`` -1 for the lower end, +1 for the upper): which way the end is read off
    each centre plane it lies on (``_off_the_centre_planes``), zero along the planes it is not on."""
    centre = 2 ** (field.max_level - 1)
    rows = np.arange(len(axis))
    on = idx == centre                                    # [E, 3] on the centre plane normal to each axis
    nudge = np.where(on, np.asarray(signs, dtype=float)[None, :], 0.0)   # in the plane: to the side asked for
    nudge[rows, axis] = np.where(on[rows, axis], end, 0.0)             # across it: beyond the edge's end
    return grid_number(idx, field.max_level), nudge


class _NudgedNearest:
    """Nearest surface points of grid corners read ``NUDGE`` of the finest cell off them, each (corner, nudge)
    queried once: a corner on a centre plane ends up to six edges, each read from up to seven sides
    (``_plane_sides``), most of them the same nudged point (~30k queries of ~7k points at 86k faces).

    requests: (grid numbers [N], nudges [N, 3] in {-1, 0, 1}) pairs, all queried together at construction."""

    def __init__(self, field: DistanceField, requests):
        keys = np.concatenate([self._key(n, d) for n, d in requests] or [np.zeros(0, dtype=np.int64)])
        moved = np.concatenate([np.any(d != 0, axis=1) for _, d in requests] or [np.zeros(0, dtype=bool)])
        self.keys = unique_ints(keys[moved])
        numbers, code = self.keys // 27, self.keys % 27
        nudge = np.stack([code // 9, code // 3 % 3, code % 3], axis=1).astype(float) - 1.0
        # As the points were read one edge end at a time: the end, then the nudge added (the same floats).
        ends = field.origin + grid_index(numbers, field.max_level) * field.finest
        self.points = field.surface.nearest(ends + nudge * NUDGE * field.finest)

    @staticmethod
    def _key(numbers, nudge) -> np.ndarray:
        code = (nudge + 1).astype(np.int64) @ np.array([9, 3, 1])
        return numbers.astype(np.int64) * 27 + code

    def nearest(self, numbers, nudge) -> np.ndarray:
        """[N, 3] nearest surface points of the corners ``numbers`` [N] nudged by ``nudge`` [N, 3] (asked for
        at construction)."""
        return self.points[np.searchsorted(self.keys, self._key(numbers, nudge))]
