"""The sphere graph: where a skeleton can run inside the mesh.

Two packed spheres are joined when they overlap and the straight segment between their centres stays inside
the mesh, so graph paths are paths through the body's interior. Shortest-path lengths between all pairs of
spheres are what the embedding measures bones with.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .distance import DistanceField
from .medial import Spheres


@dataclass
class SphereGraph:
    """centers [S, 3], radii [S] of the spheres; edges [E, 2] sphere index pairs (i < j) with lengths [E];
    distances [S, S] shortest-path length between every pair (inf between components);
    predecessors [S, S] predecessor of node j on the shortest path from i (-9999 where none)."""
    centers: np.ndarray
    radii: np.ndarray
    edges: np.ndarray
    lengths: np.ndarray
    distances: np.ndarray
    predecessors: np.ndarray

    def path(self, start: int, end: int) -> list[int]:
        """Node indices of the shortest path from ``start`` to ``end``, both included."""
        nodes = [end]
        while nodes[-1] != start:
            previous = int(self.predecessors[start, nodes[-1]])
            if previous < 0:
                raise ValueError(f"spheres {start} and {end} are not connected")
            nodes.append(previous)
        return nodes[::-1]

    def neighbours(self) -> list[np.ndarray]:
        """Adjacency lists: neighbours()[i] = indices of the spheres joined to sphere i."""
        out = [[] for _ in range(len(self.radii))]
        for i, j in self.edges:
            out[i].append(j)
            out[j].append(i)
        return [np.array(sorted(n), dtype=np.int64) for n in out]


def segments_inside(field: DistanceField, starts: np.ndarray, ends: np.ndarray, samples: int = 8,
                    margin: float = 0.0) -> np.ndarray:
    """[N] bool: whether each segment starts[i] -> ends[i] ([N, 3] each) stays at depth > margin."""
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    points = starts[:, None, :] * (1 - t) + ends[:, None, :] * t
    depth = field.depth(points.reshape(-1, 3)).reshape(len(starts), samples)
    return np.all(depth > margin, axis=1)


def sphere_graph(field: DistanceField, spheres: Spheres) -> SphereGraph:
    """Join overlapping spheres whose connecting segment stays inside, then keep the largest connected part.

    Small pieces the interior test cut off (an eye, a button, a loose accessory) carry no limb the template
    could use; the skin attachment still weights them.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, shortest_path
    from scipy.spatial import cKDTree

    c, r = spheres.centers, spheres.radii
    pairs = cKDTree(c).query_pairs(2 * float(r.max()), output_type="ndarray")
    if len(pairs):
        gap = np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1)
        overlap = gap < r[pairs[:, 0]] + r[pairs[:, 1]]
        pairs = pairs[overlap]
        if len(pairs):
            pairs = pairs[segments_inside(field, c[pairs[:, 0]], c[pairs[:, 1]])]
    n = len(r)
    lengths = np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1) if len(pairs) else np.zeros(0)
    adjacency = coo_matrix((lengths, (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr() if len(pairs) \
        else coo_matrix((n, n)).tocsr()
    _, labels = connected_components(adjacency, directed=False)
    # The part holding the most sphere volume is the body.
    volume = np.bincount(labels, weights=r ** 3)
    keep = np.flatnonzero(labels == int(np.argmax(volume)))
    remap = np.full(n, -1)
    remap[keep] = np.arange(len(keep))
    inside_part = (remap[pairs[:, 0]] >= 0) & (remap[pairs[:, 1]] >= 0) if len(pairs) else np.zeros(0, bool)
    edges = np.sort(remap[pairs[inside_part]], axis=1) if len(pairs) else np.zeros((0, 2), np.int64)
    lengths = lengths[inside_part]
    m = len(keep)
    adjacency = coo_matrix((lengths, (edges[:, 0], edges[:, 1])), shape=(m, m)).tocsr()
    distances, predecessors = shortest_path(adjacency, directed=False, return_predecessors=True)
    return SphereGraph(centers=c[keep], radii=r[keep], edges=edges, lengths=lengths,
                       distances=distances, predecessors=predecessors)
