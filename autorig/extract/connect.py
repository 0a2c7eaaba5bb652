"""The voxel graphs of the template-free skeleton, and a connected DMS to grow paths on.

A discrete medial surface is never in one piece: it breaks where limbs flare into the body (the EDM climbs
steeply there, so no voxel passes the medial test), along thin parts a voxel or two across, and between the
separate solids of a model built from parts. The path tree needs one connected graph, so the pieces are joined
by the cheapest centralised routes through the solid between them (Mehlhorn's approximation of the Steiner
tree: one multi-source Dijkstra from every DMS voxel, then a minimum spanning tree of the pieces over the
routes where their Dijkstra regions meet). The routes run where the paths of the paper would run, since they
minimise the same measure. Pieces in separate solids (a model built of parts) are then joined by straight gap
edges, each between a piece and the nearest voxel of the pieces before it, at the piece's nearest voxel.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra, minimum_spanning_tree
from scipy.spatial import cKDTree

from .medial import NEIGHBOURS

# Routes' costs lean by this fraction per box diagonal toward -x, then -z, then -y (``VoxelGraph._tilt``): a
# mirror-symmetric shape has routes of equal cost on either side of each mirror plane, and which one the
# Dijkstra and the spanning tree took fell to rounding (OpenClonk's squid: pieces of its medial surface joined
# one way or the other as 1e-6 of its height of noise fell, 11 chains or 12). Such noise is 1e-4 of a voxel at 96
# voxels, and moves 1/d^3 a few voxels deep by about 1e-4 of itself; this leans mirror images apart by 1e-3 of
# their cost or more when they lie a tenth of the box apart, and changes no cost by more than 0.6 %.
COST_TILT = 0.01

# One of each pair of opposite neighbour offsets [13, 3]: each voxel edge once.
HALF_NEIGHBOURS = NEIGHBOURS[13:]


@dataclass(frozen=True)
class VoxelGraph:
    """Voxels joined to their 26 neighbours (plus gap edges between separate solids).

    voxels   [N, 3] int64 grid coordinates
    depth    [N] EDM at each voxel (voxels)
    edges    [E, 2] int64 node pairs, each edge once
    lengths  [E] Euclidean length of each edge (voxels)
    """
    voxels: np.ndarray
    depth: np.ndarray
    edges: np.ndarray
    lengths: np.ndarray

    def matrix(self, weights: np.ndarray) -> sp.csr_matrix:
        """Symmetric [N, N] sparse matrix holding weights [E] on the graph's edges."""
        n = len(self.voxels)
        i, j = self.edges.T
        return sp.csr_matrix((np.concatenate([weights, weights]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                             shape=(n, n))

    def centralised_costs(self) -> np.ndarray:
        """[E] cost of each edge under the paper's measure W = sum of 1/d^3 over a path's voxels: the edge's
        length times the mean 1/d^3 of its ends, so a path's cost integrates 1/d^3 along it, the same on
        straight and diagonal steps."""
        # A route between medial pieces may graze the surface, where the depth tends to 0: a floor of a
        # quarter voxel keeps its cost finite without changing which route is cheapest.
        w = 1.0 / np.maximum(self.depth, 0.25) ** 3
        return self.lengths * 0.5 * (w[self.edges[:, 0]] + w[self.edges[:, 1]]) * self._tilt()

    def _tilt(self) -> np.ndarray:
        """[E] 1 + COST_TILT x where each edge lies across the graph's box (-x, -z, -y first; see COST_TILT)."""
        lo, hi = self.voxels.min(axis=0), self.voxels.max(axis=0)
        middle = 0.5 * (self.voxels[self.edges[:, 0]] + self.voxels[self.edges[:, 1]])
        across = (middle - 0.5 * (lo + hi)) / max(float(np.linalg.norm(hi - lo)), 1.0)
        return 1.0 + COST_TILT * (across @ np.array([1.0, 0.25, 0.5]))

    def subgraph(self, nodes: np.ndarray) -> VoxelGraph:
        """The graph induced on nodes [M] (ascending node indices), renumbered 0..M-1 in that order."""
        renumber = np.full(len(self.voxels), -1, dtype=np.int64)
        renumber[nodes] = np.arange(len(nodes))
        kept = np.all(renumber[self.edges] >= 0, axis=1)
        return VoxelGraph(self.voxels[nodes], self.depth[nodes], renumber[self.edges[kept]], self.lengths[kept])


def inside_graph(depth: np.ndarray) -> VoxelGraph:
    """The graph of all inside voxels (depth > 0 in depth [X, Y, Z], outermost layer empty), in C order."""
    voxels = np.argwhere(depth > 0)
    ids = np.full(depth.shape, -1, dtype=np.int64)
    ids[tuple(voxels.T)] = np.arange(len(voxels))
    pairs, lengths = [], []
    for offset in HALF_NEIGHBOURS:
        # Inside voxels never touch the grid's border, so every neighbour index is in range.
        other = ids[tuple((voxels + offset).T)]
        found = other >= 0
        pairs.append(np.stack([np.flatnonzero(found), other[found]], axis=1))
        lengths.append(np.full(int(found.sum()), np.linalg.norm(offset)))
    return VoxelGraph(voxels, depth[tuple(voxels.T)], np.concatenate(pairs), np.concatenate(lengths))


def connected_medial(graph: VoxelGraph, medial: np.ndarray) -> VoxelGraph:
    """The DMS joined into one piece by centralised routes through the solid.

    graph: ``inside_graph``; medial [M, 3] DMS voxels. Returns the subgraph of ``graph`` on the DMS voxels and
    the voxels of the joining routes.
    """
    dms = _node_indices(graph.voxels, medial)
    keep = np.zeros(len(graph.voxels), dtype=bool)
    keep[dms] = True
    medial_graph = graph.subgraph(dms)
    _, piece = connected_components(medial_graph.matrix(medial_graph.lengths), directed=False)
    piece_of = np.full(len(graph.voxels), -1, dtype=np.int64)
    piece_of[dms] = piece

    cost = graph.centralised_costs()
    dist, pred, source = dijkstra(graph.matrix(cost), indices=dms, min_only=True, return_predecessors=True)
    region = piece_of[source]                                  # [N] the DMS piece each voxel is closest to
    a, b = graph.edges.T
    crossing = np.flatnonzero(region[a] != region[b])
    if len(crossing):
        route_cost = dist[a[crossing]] + cost[crossing] + dist[b[crossing]]
        lo = np.minimum(region[a[crossing]], region[b[crossing]])
        hi = np.maximum(region[a[crossing]], region[b[crossing]])
        # The cheapest crossing edge of each pair of pieces.
        order = np.lexsort((crossing, route_cost, hi, lo))
        first = np.ones(len(order), dtype=bool)
        first[1:] = (lo[order][1:] != lo[order][:-1]) | (hi[order][1:] != hi[order][:-1])
        best = order[first]
        n_pieces = int(piece.max()) + 1
        pieces = sp.csr_matrix((route_cost[best], (lo[best], hi[best])), shape=(n_pieces, n_pieces))
        tree = minimum_spanning_tree(pieces).tocoo()
        chosen = best[np.flatnonzero(np.isin(lo[best] * n_pieces + hi[best], tree.row * n_pieces + tree.col))]
        ends = np.concatenate([a[crossing[chosen]], b[crossing[chosen]]])
        keep[_trace_back(pred, ends)] = True
    return join_pieces(graph.subgraph(np.flatnonzero(keep)))


def join_pieces(graph: VoxelGraph) -> VoxelGraph:
    """Add gap edges until the graph is connected (its pieces lie in separate solids): the pieces, largest
    first, each join the ones before them by the shortest edge between a voxel of theirs and one already joined.
    Returns the graph with the gap edges appended."""
    count, label = connected_components(graph.matrix(graph.lengths), directed=False)
    if count == 1:
        return graph
    order = np.lexsort((np.arange(count), -np.bincount(label, minlength=count)))   # largest first
    joined = label == order[0]
    gaps = []
    for piece in order[1:]:
        # The piece hangs by its end nearest to the rest (a separate leg by its hip, not its middle), so that a
        # path runs along it from where it meets the body instead of arriving halfway down it.
        own, others = np.flatnonzero(label == piece), np.flatnonzero(joined)
        distance, nearest = cKDTree(graph.voxels[others]).query(graph.voxels[own])
        k = int(np.argmin(distance))
        gaps.append((own[k], others[nearest[k]], distance[k]))
        joined[label == piece] = True
    edges = np.array([(a, b) for a, b, _ in gaps], dtype=np.int64)
    lengths = np.array([d for _, _, d in gaps], dtype=np.float64)
    return VoxelGraph(graph.voxels, graph.depth, np.concatenate([graph.edges, edges]),
                      np.concatenate([graph.lengths, lengths]))


def most_central(graph: VoxelGraph, nodes: np.ndarray) -> int:
    """The most central of nodes [K]: among those within one voxel of their largest depth (a uniform tube has
    a run of equally deep voxels), the one nearest their mean position (ties: the first)."""
    deep = nodes[graph.depth[nodes] >= graph.depth[nodes].max() - 1.0]
    centre = graph.voxels[deep].mean(axis=0)
    return int(deep[np.argmin(np.linalg.norm(graph.voxels[deep] - centre, axis=1))])


def _node_indices(voxels: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Positions [K] in voxels [N, 3] (grid coordinates in C order) of the voxels query [K, 3] (among them)."""
    shape = tuple(voxels.max(axis=0) + 1)
    return np.searchsorted(np.ravel_multi_index(voxels.T, shape), np.ravel_multi_index(query.T, shape))


def _trace_back(pred: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """All nodes on the predecessor chains from starts [K] back to their Dijkstra sources (pred [N], -9999 at
    the sources), walking every chain one step at a time together."""
    visited = [starts]
    current = starts
    while len(current):
        current = pred[current]
        current = current[current >= 0]
        visited.append(current)
    return np.unique(np.concatenate(visited))
