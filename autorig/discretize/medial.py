"""Approximate medial surface and the packing of maximal inscribed spheres (the discretization's second half).

The medial surface is where the distance field has a crease: a point there is equally far from two different
parts of the surface. The octree stores, at every cell corner, the nearest surface point; along a cell edge
whose two inside corners look at surface points in clearly different directions, the medial surface crosses
the edge where the point is equally far from both surface points (the bisector plane of the two). Each such
crossing is a medial sample, and its distance to the surface is the radius of a maximal inscribed sphere.

A corner within a rounding error of a crease between two other surface parts could read its nearest point on
either, and an edge at it turn past the threshold or not: such an end is read through both parts, and a
crossing only the farther one gives counts with a weight that is 1 while the two parts are tied to within
what a re-export's rounding can change and fades to 0 soon after (``_Ties``).

Spheres are then packed greedily, largest first, keeping a sphere only if its centre lies in no sphere kept before.
Few large spheres fill the torso, chains of small ones the limbs: the graph on them is small but follows every limb.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..input.facing import unique_ints
from .distance import CORNERS, DistanceField, grid_index, grid_number

# Pairs of CORNERS indices that differ along exactly one axis: the 12 edges of a cell.
EDGES = np.array([(a, b) for a in range(8) for b in range(a + 1, 8) if np.abs(CORNERS[a] - CORNERS[b]).sum() == 1])
EDGE_AXIS = np.argmax(CORNERS[EDGES[:, 1]] - CORNERS[EDGES[:, 0]], axis=1)   # [12] the axis each edge runs along


@dataclass
class MedialSamples:
    """points [M, 3] on the approximate medial surface; radii [M] their distance to the surface; weights [M] in
    (0, 1]: 1 for a crossing its edge's ends read as they are, less for one they read only through a nearly tied
    surface part (``TIE``; None: all 1)."""
    points: np.ndarray
    radii: np.ndarray
    weights: np.ndarray | None = None


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
    if not len(leaf):   # no edge inside (a mesh lost in its own box, a stray vertex far away): no samples
        return MedialSamples(points=np.zeros((0, 3)), radii=np.zeros(0), weights=np.zeros(0))
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
    # Both ends of every edge as read (a corner on a centre plane read off it), side by side.
    fa, fb = _corner_faces(field, ia), _corner_faces(field, ib)
    b_number = grid_number(b_idx, field.max_level)
    reads = []
    for signs, rows in sides:
        part = (lambda x: x) if len(rows) == len(axis) else (lambda x: x[rows])   # every edge: no copies
        reads.append(tuple(_end_reads(field, part(n), part(idx), part(axis), part(x), part(c), part(fc), end, signs,
                                      nudged)
                           for n, idx, x, c, fc, end in ((a_number, a_idx, a, ca, fa, -1.0),
                                                         (b_number, b_idx, b, cb, fb, 1.0))))
    ties = _Ties(field, reads, nudged)
    points, radii, weights = [], [], []
    for (signs, rows), (read_a, read_b) in zip(sides, reads):
        part = (lambda x: x) if len(rows) == len(axis) else (lambda x: x[rows])   # every edge: no copies
        p, r, crossed = _crossings(part(a), part(b), read_a.nearest, read_b.nearest, part(da), part(db),
                                   cos_turn, with_edges=True)
        tied_p, tied_r, tied_w = ties.crossings(part(a), part(b), (read_a, read_b), part(da), part(db),
                                                cos_turn, np.flatnonzero(~crossed))
        points += [p, tied_p]
        radii += [r, tied_r]
        weights += [np.ones(len(r)), tied_w]
    return MedialSamples(points=np.concatenate(points), radii=np.concatenate(radii),
                         weights=np.concatenate(weights))


def _crossings(a, b, ca, cb, da, db, cos_turn, with_edges: bool = False):
    """Where the edges a-b cross the medial surface of the nearest points ca, cb: (points, radii), and with
    ``with_edges`` a mask [E] of the edges that gave one."""
    ga = (a - ca) / da[:, None]
    gb = (b - cb) / db[:, None]
    turned = np.einsum("ij,ij->i", ga, gb) < cos_turn
    turned_rows = np.flatnonzero(turned)
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
    if with_edges:
        crossed = np.zeros(len(turned), dtype=bool)
        crossed[turned_rows[ok]] = True
        return points, radii, crossed
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
    weights = np.ones(len(samples.radii)) if samples.weights is None else samples.weights
    # A sample read through a nearly tied surface part (``TIE``) counts as a sphere of its radius times its
    # weight when visited and kept: it fades out of the packing as the tie it hangs on fades.
    keep_mask &= samples.radii * weights > min_radius
    points, radii = samples.points[keep_mask], samples.radii[keep_mask]
    visit = radii * weights[keep_mask]
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
                        -np.floor(visit / RADIUS_STEP)))
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
REEXPORT = 1e-6   # heights: how far a re-export's rounding may move a vertex (issue 37's noise)
TIE = 10 * REEXPORT   # heights: a surface part this little farther from an edge end than its nearest is tied with it


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
    ends = ((a_idx, a, ca, -1.0), (b_idx, b, cb, 1.0))
    if nudged is None:
        centre = 2 ** (field.max_level - 1)
        nudged = _NudgedNearest(field, [_nudges(field, idx[moved], axis[moved], end, signs)
                                        for idx, _, _, end in ends
                                        for moved in [np.flatnonzero(np.any(idx == centre, axis=1))]])
    out = [_end_reads(field, grid_number(idx, field.max_level), idx, axis, x, c, np.zeros(len(c), dtype=np.int64),
                      end, signs, nudged).nearest for idx, x, c, end in ends]
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
        self.points, self.faces = field.surface.nearest_and_faces(ends + nudge * NUDGE * field.finest)
        self.ends, self.nudge = ends, nudge

    @staticmethod
    def _key(numbers, nudge) -> np.ndarray:
        code = (nudge + 1).astype(np.int64) @ np.array([9, 3, 1])
        return numbers.astype(np.int64) * 27 + code

    def nearest(self, numbers, nudge) -> np.ndarray:
        """[N, 3] nearest surface points of the corners ``numbers`` [N] nudged by ``nudge`` [N, 3] (asked for
        at construction)."""
        return self.points[np.searchsorted(self.keys, self._key(numbers, nudge))]

    def nearest_and_faces(self, numbers, nudge) -> tuple[np.ndarray, np.ndarray]:
        """(``nearest``, [N] the triangles those points lie on)."""
        rows = np.searchsorted(self.keys, self._key(numbers, nudge))
        return self.points[rows], self.faces[rows]


def _corner_faces(field: DistanceField, rows: np.ndarray) -> np.ndarray:
    """[N] the triangle of the nearest surface point of the field's corners ``rows``."""
    if field.corner_face is not None:
        return field.corner_face[rows]
    return field.surface.nearest_and_faces(field.corner_nearest[rows])[1]   # the triangle under the point


@dataclass
class _Reads:
    """Where one end of each of a set of edges is read: the grid numbers of its corner [E], a key [E] of the
    read (the corner and which way it is nudged, ``_NudgedNearest._key``), the point read [E, 3], its nearest
    surface point [E, 3] and the triangle that lies on [E]."""
    numbers: np.ndarray
    keys: np.ndarray
    points: np.ndarray
    nearest: np.ndarray
    faces: np.ndarray


def _end_reads(field: DistanceField, numbers, idx, axis, ends, nearest, faces, end: float, signs,
               nudged) -> _Reads:
    """The ``_Reads`` of one end of each edge: the corner itself, or nudged off a centre plane
    (``_off_the_centre_planes``), with the same nearest points as ``_off_the_centre_planes`` gives."""
    centre = 2 ** (field.max_level - 1)
    moved = np.flatnonzero(np.any(idx == centre, axis=1))
    keys = numbers.astype(np.int64) * 27 + _UNMOVED      # _NudgedNearest._key of a read without a nudge
    if not len(moved):
        return _Reads(numbers, keys, ends, nearest, faces)
    points, nearest, faces = ends.copy(), nearest.copy(), faces.copy()
    moved_numbers, nudge = _nudges(field, idx[moved], axis[moved], end, signs)
    # as _NudgedNearest computed them: the end's grid point, then the nudge added (the same floats)
    points[moved] = (field.origin + grid_index(moved_numbers, field.max_level) * field.finest
                     + nudge * NUDGE * field.finest)
    nearest[moved], faces[moved] = nudged.nearest_and_faces(moved_numbers, nudge)
    keys[moved] = _NudgedNearest._key(moved_numbers, nudge)
    return _Reads(numbers, keys, points, nearest, faces)


_UNMOVED = 13   # _NudgedNearest._key's code (mod 27) of a corner read where it is


def _tie_weight(margin):
    """The weight [N] of a reading through a surface part ``margin`` [N] (heights) farther than the nearest: 1
    up to half of ``TIE`` (where a rounding error's change of the mesh cannot reach it, from a tie), then down
    smoothly (smoothstep) to 0 at ``TIE``."""
    x = np.clip(2.0 * np.asarray(margin) / TIE - 1.0, 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


class _Ties:
    """The surface parts nearly tied with the nearest of an edge end (``TIE``), and the crossings an edge has
    only when its ends are read through them.

    A grid corner on (or within a rounding error of) a crease of the distance field between two surface parts
    reads its nearest point on either, as the floats fall; whether an edge at it turns by more than the angle
    asked for can hang on that, and with it a sample as large as the body there (a 0 A.D. hippo's neck: a
    corner within 1e-6 of the height of the crease between two triangles of the neck's side, its edge turning 61 or 79
    degrees from the top of the neck). Such an end is read through either part: a crossing found only through
    the farther one counts with the weight of its margin (``_tie_weight``), 1 near the tie, so that the
    reading that floats chose makes no difference, and 0 from ``TIE`` on, so that the samples change
    continuously with the mesh, and not at all where no part is nearly tied. An end's candidate parts are the
    triangles nearest it and the other ends of the edges at its corner.

    pairs: the (a-end, b-end) ``_Reads`` of every side's edges (``_plane_sides``); nudged: the nudged reads'
    nearest points (``_NudgedNearest``)."""

    def __init__(self, field: DistanceField, pairs: list[tuple[_Reads, _Reads]], nudged: "_NudgedNearest"):
        vertices, triangles = field.surface.vertices, field.surface.faces
        n_faces = np.int64(len(triangles))
        # (corner, triangle) pairs: the triangle of each edge's other end, and a corner's own when it is read
        # more than one way (nudged off a centre plane to either side). Only those that can differ from the
        # read's own triangle are listed (the own one is no candidate): a third of the edges' ends or fewer.
        listed = []
        for ra, rb in pairs:
            differ = ra.faces != rb.faces
            for here, there in ((ra, rb), (rb, ra)):
                rows = differ | (here.keys % 27 != _UNMOVED)
                listed.append(here.numbers[rows].astype(np.int64) * n_faces + there.faces[rows])
                moved = here.keys % 27 != _UNMOVED
                listed.append(here.numbers[moved].astype(np.int64) * n_faces + here.faces[moved])
        candidates = unique_ints(np.concatenate(listed))   # np.unique hashes: 0.04 s of 200k pairs
        # The distinct reads of the corners that have candidates: a corner read where it is (unless it lies on a
        # centre plane, where it is only read nudged off it), or nudged one way (``_NudgedNearest``, each once).
        corner = candidates // n_faces
        corners_listed = corner[np.r_[True, corner[1:] != corner[:-1]]] if len(corner) else corner
        idx = grid_index(corners_listed, field.max_level)
        plain = corners_listed[~np.any(idx == 2 ** (field.max_level - 1), axis=1)]
        rows = field.corner_row[plain]
        moved = nudged.keys // 27     # which of them are listed, by a binary search (corners_listed is sorted)
        at = np.minimum(np.searchsorted(corners_listed, moved), max(len(corners_listed) - 1, 0))
        moved = np.flatnonzero(corners_listed[at] == moved) if len(corners_listed) else np.zeros(0, dtype=np.int64)
        read_keys = np.concatenate([plain * 27 + _UNMOVED, nudged.keys[moved]])
        order = np.argsort(read_keys, kind="stable")
        read_keys = read_keys[order]
        first_numbers = np.concatenate([plain, nudged.keys[moved] // 27])[order]
        point = np.concatenate([field.origin + grid_index(plain, field.max_level) * field.finest,
                                nudged.ends[moved] + nudged.nudge[moved] * NUDGE * field.finest])[order]
        nearest = np.concatenate([field.corner_nearest[rows], nudged.points[moved]])[order]
        own = np.concatenate([_corner_faces(field, rows), nudged.faces[moved]])[order]
        start = np.searchsorted(candidates, first_numbers * n_faces)
        count = np.searchsorted(candidates, (first_numbers + 1) * n_faces) - start
        read = np.repeat(np.arange(len(read_keys)), count)
        face = candidates[start[read] + np.arange(len(read)) - np.repeat(np.cumsum(count) - count, count)] % n_faces
        read, face = read[face != own[read]], face[face != own[read]]
        # Measured a chunk of candidates at a time (each row on its own: the same as all at once, in less memory);
        # each read's nearly tied parts come out by the read's key (sorted: read is), with the foot on each.
        # Most candidates' planes are out of the tie's reach: a first look through each triangle's plane, worked
        # out once, a billionth of the field wider than ``_tied_parts``' own, leaves it a third (armadillo 20k:
        # 166k -> 56k), slivers (their normals too uncertain for the billionth) to it.
        side, other = (vertices[triangles[:, k]] - vertices[triangles[:, 0]] for k in (1, 2))
        cross = np.cross(side, other)        # as ``_tied_parts`` works it out per candidate: the same floats
        length = np.linalg.norm(cross, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            normal = cross / np.where(length > 1e-6 * np.linalg.norm(side, axis=1) * np.linalg.norm(other, axis=1),
                                      length, np.nan)[:, None]
        offset = np.einsum("ij,ij->i", normal, vertices[triangles[:, 0]])
        reach = np.linalg.norm(point - nearest, axis=1) + TIE + 1e-9 * field.size
        keys, feet, margins = [], [], []
        for lo in range(0, len(read), TIE_CHUNK):
            rows, faces = read[lo:lo + TIE_CHUNK], face[lo:lo + TIE_CHUNK]
            plane = np.abs(np.einsum("ij,ij->i", normal[faces], point[rows]) - offset[faces])
            maybe = ~(plane >= reach[rows])            # NaN (a sliver): maybe
            k, f, m = _tied_parts(vertices, triangles, point, nearest, rows[maybe], faces[maybe], cross, length)
            keys.append(read_keys[k])
            feet.append(f)
            margins.append(m)
        self.key = np.concatenate(keys) if keys else np.zeros(0, dtype=np.int64)
        self.foot = np.concatenate(feet) if feet else np.zeros((0, 3))
        self.weight = _tie_weight(np.maximum(np.concatenate(margins) if margins else np.zeros(0), 0.0))

    def crossings(self, a, b, reads: tuple[_Reads, _Reads], da, db, cos_turn, edges):
        """(points, radii, weights) of the crossings of the edges ``edges`` (indices) that only a reading of
        their ends through nearly tied parts finds: at most one per edge, the one of the largest weight (then
        the largest radius, then the lowest coordinates: whatever the order of the ends' parts)."""
        empty = np.zeros((0, 3)), np.zeros(0), np.zeros(0)
        spans = [(np.searchsorted(self.key, r.keys[edges]), np.searchsorted(self.key, r.keys[edges], side="right"))
                 for r in reads]
        (lo_a, hi_a), (lo_b, hi_b) = spans
        tied = (hi_a > lo_a) | (hi_b > lo_b)
        edges, lo_a, hi_a, lo_b, hi_b = edges[tied], lo_a[tied], hi_a[tied], lo_b[tied], hi_b[tied]
        if not len(edges):
            return empty
        # Every combination of the two ends' options (-1: as read, else a row of the tied parts), but the
        # ends as read both.
        ka, kb = hi_a - lo_a + 1, hi_b - lo_b + 1
        pair = np.repeat(np.arange(len(edges)), ka * kb)
        within = np.arange(len(pair)) - np.repeat(np.cumsum(ka * kb) - ka * kb, ka * kb)
        ia, ib = within // kb[pair], within % kb[pair]
        opt_a = np.where(ia == 0, -1, lo_a[pair] + ia - 1)
        opt_b = np.where(ib == 0, -1, lo_b[pair] + ib - 1)
        keep = (opt_a >= 0) | (opt_b >= 0)
        pair, opt_a, opt_b = pair[keep], opt_a[keep], opt_b[keep]
        rows = edges[pair]
        feet, weight = [], np.ones(len(pair))
        for r, opt in zip(reads, (opt_a, opt_b)):
            feet.append(np.where((opt < 0)[:, None], r.nearest[rows], self.foot[np.maximum(opt, 0)]))
            weight *= np.where(opt < 0, 1.0, self.weight[np.maximum(opt, 0)])
        p, r, crossed = _crossings(a[rows], b[rows], feet[0], feet[1], da[rows], db[rows], cos_turn,
                                   with_edges=True)
        pair, weight = pair[crossed], weight[crossed]
        if not len(pair):
            return empty
        order = np.lexsort((p[:, 2], p[:, 1], p[:, 0], -r, -weight, pair))
        first = order[np.r_[True, pair[order][1:] != pair[order][:-1]]]
        return p[first], r[first], weight[first]


TIE_CHUNK = 1 << 16   # candidate (read, triangle) pairs measured at once by ``_Ties``


def _tied_parts(vertices, triangles, point, nearest, read, face, cross, length):
    """(read rows [T], feet [T, 3], margins [T]) of the candidates (``read`` [N] rows of ``point`` and
    ``nearest``, ``face`` [N] triangles) nearly tied with their read's nearest point (``_Ties``); ``cross`` [F, 3]
    and ``length`` [F]: each triangle's (b - a) x (c - a) and its norm."""
    # A triangle is no nearer than its plane: most candidates' planes are farther than the tie reaches.
    at, own = point[read], nearest[read]
    with np.errstate(divide="ignore", invalid="ignore"):
        plane = np.abs(np.einsum("ij,ij->i", at - vertices[triangles[face, 0]], cross[face])) / length[face]
    depth = np.linalg.norm(at - own, axis=1)
    maybe = ~(plane >= depth + TIE)      # a degenerate triangle (no plane) is measured
    read, at, own, depth, corners = read[maybe], at[maybe], own[maybe], depth[maybe], vertices[triangles[face[maybe]]]
    foot = _closest_on_triangles(at, corners[:, 0], corners[:, 1], corners[:, 2])
    margin = np.linalg.norm(at - foot, axis=1) - depth
    # Tied, and another part: a triangle whose nearest point is the read's own (a neighbour of its triangle at
    # the edge or corner the nearest point lies on) turns no edge another way.
    near = (margin < TIE) & (np.linalg.norm(foot - own, axis=1) > TIE)
    return read[near], foot[near], margin[near]


def _closest_on_triangles(p, a, b, c):
    """[N, 3] the point of each triangle (a, b, c) [N, 3] nearest p [N, 3]: p's projection on the triangle's
    plane where that falls inside it, else the nearest point of its three edges (a degenerate triangle, a
    segment or a point, has no inside)."""
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)    # noqa: E731
    ab, ac, ap = b - a, c - a, p - a
    d00, d01, d11, d20, d21 = dot(ab, ab), dot(ab, ac), dot(ac, ac), dot(ap, ab), dot(ap, ac)
    area = d00 * d11 - d01 * d01                      # squared, times 4: Gram determinant of ab, ac
    with np.errstate(divide="ignore", invalid="ignore"):
        v = (d11 * d20 - d01 * d21) / area
        w = (d00 * d21 - d01 * d20) / area
        inside = (area > 1e-12 * d00 * d11) & (v >= 0) & (w >= 0) & (v + w <= 1)
    best = a + ab * np.where(inside, v, 0.0)[:, None] + ac * np.where(inside, w, 0.0)[:, None]
    best_sq = np.where(inside, dot(p - best, p - best), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):
        se = e - s
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(np.nan_to_num(dot(p - s, se) / dot(se, se)), 0.0, 1.0)
        q = s + se * t[:, None]
        sq = dot(p - q, p - q)
        nearer = sq < best_sq
        best = np.where(nearer[:, None], q, best)
        best_sq = np.where(nearer, sq, best_sq)
    return best
