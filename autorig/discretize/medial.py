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
    _, first = np.unique(edge_key, return_index=True)
    a_number, axis, length = a_number[first], EDGE_AXIS[edge[first]], edge_len[leaf[first]]
    a_idx = grid_index(a_number, field.max_level)
    b_idx = a_idx.copy()
    b_idx[np.arange(len(b_idx)), axis] += length
    ia, ib = field.corner_row[a_number], field.corner_rows(b_idx)
    da, db = field.corner_depth[ia], field.corner_depth[ib]
    a = field.origin + a_idx * field.finest
    b = field.origin + b_idx * field.finest
    ca, cb = field.corner_nearest[ia], field.corner_nearest[ib]
    ca, cb = _off_the_centre_planes(field, a_idx, b_idx, axis, a, b, ca, cb)
    ga = (a - ca) / da[:, None]
    gb = (b - cb) / db[:, None]
    turned = np.einsum("ij,ij->i", ga, gb) < np.cos(np.radians(min_angle_degrees))
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
    return MedialSamples(points=points, radii=radii)


def pack_spheres(samples: MedialSamples, min_radius: float = 0.0) -> Spheres:
    """Greedy packing: visit samples by decreasing radius; keep one if no kept sphere contains its centre.

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
    order = np.lexsort((points[:, 2], points[:, 1], points[:, 0], -radii))  # deterministic ties
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


NUDGE = 0.05   # of the finest cell: how far off a centre-plane corner its edge's nearest point is read


def _off_the_centre_planes(field: DistanceField, a_idx, b_idx, axis, a, b, ca, cb):
    """(ca, cb) with the nearest surface point of each edge end that lies on one of the octree's three centre
    planes read a little off the plane instead (``NUDGE`` of the finest cell): beyond the edge's end for the
    plane across the edge, to the plane's lower side for a plane the edge lies in.

    A mirror-symmetric body's mid-plane is the octree's centre plane (the cube is centred on the body's box),
    so every corner on it is equally far from the left and the right side: which of the two its stored nearest
    point lies on is a tie that the smallest change of the mesh flips (a 0 A.D. rhino's 814 mid-plane corners
    under 1e-6 noise), and with it whether the edges at it cross the medial surface, the samples there and the
    spheres packed from them. Read from beyond the end, an edge across the plane sees the crease at the plane
    whatever the tie; an edge in the plane reads both its ends from one side, so it finds only the creases
    that side has (its mirror image's are the same on a symmetric body).
    """
    centre = 2 ** (field.max_level - 1)
    rows = np.arange(len(axis))
    out = []
    for idx, ends, nearest, sign in ((a_idx, a, ca, -1.0), (b_idx, b, cb, 1.0)):
        on = idx == centre                       # [E, 3] on the centre plane normal to each axis
        nudge = np.where(on, -1.0, 0.0)          # in the plane: to its lower side
        nudge[rows, axis] = np.where(on[rows, axis], sign, 0.0)   # across it: beyond the edge's end
        moved = np.flatnonzero(on.any(axis=1))
        nearest = nearest.copy()
        if len(moved):
            nearest[moved] = field.surface.closest(ends[moved] + nudge[moved] * NUDGE * field.finest)[1]
        out.append(nearest)
    return out[0], out[1]
