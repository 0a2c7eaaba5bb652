"""The working copy of a mesh (``autorig.input.mesh.prepare``): its vertices merged where a file repeats them,
its degenerate and repeated triangles dropped, and the map back to the file's vertices."""
from __future__ import annotations

import numpy as np

from .facing import face_cross, used_vertices

# Heights: working vertices this close are one (``working_copy``): ten times a re-export's rounding (1e-6 of
# the height, which moves two copies of a seam's vertex apart by up to 2e-6), far below the distance field's
# finest cell (about 0.009 of the height).
WELD = 1e-5


def working_copy(V: np.ndarray, F: np.ndarray, canonical: np.ndarray, area_tolerance: float):
    """The cleaned mesh for discretisation: (work_vertices [W, 3], work_faces [G, 3], work_index [V]); triangles of
    area ``area_tolerance`` or less are dropped.

    Vertices are merged when their input coordinates are bit-identical (after -0.0 -> 0.0), as seams and STL
    corners are, and when they lie within ``WELD`` of the height of each other (each group at its members'
    mean): a glTF's seams repeat their vertices, and a re-export's rounding that moved the copies apart by a
    millionth of the height opened every seam (the rigs of held-out glTF characters moved 2-30 % of their height).
    Parts that merely come close stay apart.
    """
    first, merged = _first_occurrences(V + 0.0)   # merged [V]: merged index of each input vertex
    positions = canonical[first]
    group = _near_groups(positions, WELD)
    if group is not None:
        count = np.bincount(group).astype(np.float64)
        sums = np.stack([np.bincount(group, weights=positions[:, k]) for k in range(3)], axis=1)
        positions = sums / count[:, None]
        merged = group[merged]
    # Rounded to 1e-9 of the height: the same mesh at another scale or offset then gives bit-identical
    # working vertices, so choices that hinge on ties (decimation of a marching-cubes mesh) come out the same.
    positions = np.round(positions, 9)             # [M, 3]
    G = merged[F]
    area = 0.5 * np.linalg.norm(face_cross(positions, G), axis=1)
    keep = (G[:, 0] != G[:, 1]) & (G[:, 1] != G[:, 2]) & (G[:, 0] != G[:, 2]) & (area > area_tolerance)
    G = G[keep]
    G = G[_first_triangles(G, len(positions))]
    used, renumber = used_vertices(len(positions), G)
    return positions[used], renumber[G], renumber[merged]


def _first_occurrences(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group identical rows of ``rows`` [N, K]. Returns (first [G] ascending index of the first row of each
    group, group [N] the group of each row, groups numbered in order of their first row)."""
    order = np.lexsort(rows.T[::-1])  # stable, so each run of equal rows lists its first row first
    sorted_rows = rows[order]
    starts = np.ones(len(rows), dtype=bool)
    starts[1:] = np.any(sorted_rows[1:] != sorted_rows[:-1], axis=1)
    run = np.cumsum(starts) - 1
    first_of_run = order[starts]
    rank = np.empty(len(first_of_run), dtype=np.int64)
    rank[np.argsort(first_of_run)] = np.arange(len(first_of_run))
    group = np.empty(len(rows), dtype=np.int64)
    group[order] = rank[run]
    return np.sort(first_of_run), group


def _near_groups(points: np.ndarray, within: float) -> np.ndarray | None:
    """[N] the group of each of ``points`` [N, 3] when some lie within ``within`` of one another (groups joined
    through such pairs, numbered in the order of their first point), or None when no two do."""
    from scipy.spatial import cKDTree
    # Coordinates past 1e100 (a stray vertex a file put at 1e154) would overflow the tree's squared distances;
    # such points are no seam's copies (bit-identical ones are merged already), so they are left alone.
    near = np.flatnonzero(np.abs(points).max(axis=1, initial=0.0) < 1e100)
    pairs = near[cKDTree(points[near]).query_pairs(within, output_type="ndarray")] if len(near) else []
    if not len(pairs):
        return None
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    n = len(points)
    _, label = connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)),
                                    directed=False)
    first = np.full(label.max() + 1, n, dtype=np.int64)
    np.minimum.at(first, label, np.arange(n))
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[label]


def _first_triangles(G: np.ndarray, n: int) -> np.ndarray:
    """[K] ascending indices of the first of each set of triangles of G [G, 3] (over n vertices) with the same
    corners, in any order: ``_first_occurrences(np.sort(G, axis=1))[0]``, by one integer key per triangle when
    n^3 fits in 63 bits (a 1M-face mesh: 0.07 s instead of 0.24 s)."""
    S = np.sort(G, axis=1)
    if n >= 2 ** 21:
        return _first_occurrences(S)[0]
    key = (S[:, 0] * n + S[:, 1]) * n + S[:, 2]
    return np.sort(np.unique(key, return_index=True)[1])   # np.unique's index: each key's first occurrence
