"""The sphere graph: where a skeleton can run inside the mesh.

Two packed spheres are joined when they overlap and the straight segment between their centres stays inside
the mesh, so graph paths are paths through the body's interior. Shortest-path lengths between all pairs of
spheres are what the embedding measures bones with. Where two parts of the body only touch, the edges between
them are cut (``autorig.discretize.contacts``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..input.facing import unique_ints
from .contacts import CONTACT_RATIO, _contacts, _nearest_corners, _surface_far, _surface_pieces
from .distance import DistanceField
from .medial import Spheres
LIMB_PIECE = 0.1   # a piece whose spheres' box is this far across (heights) may hold a limb: bridged to the body
TIE = 1e-9   # gaps this close (of the largest radius) are equal: ``_bridge_pieces`` bridges them all



@dataclass
class SphereGraph:
    """centers [S, 3], radii [S] of the spheres; edges [E, 2] sphere index pairs (i < j) with lengths [E];
    distances [S, S] shortest-path length between every pair (inf between components);
    predecessors [S, S] predecessor of node j on the shortest path from i (-9999 where none);
    shared: what depends only on the graph's connections (adjacency lists, the limb-end merge order), worked
    out once and shared with ``moved`` copies: orientation detection asks for it in eight frames."""
    centers: np.ndarray
    radii: np.ndarray
    edges: np.ndarray
    lengths: np.ndarray
    distances: "np.ndarray | ScaledMatrix"
    predecessors: np.ndarray
    shared: dict = field(default_factory=dict, repr=False, compare=False)

    def path(self, start: int, end: int) -> list[int]:
        """Node indices of the shortest path from ``start`` to ``end``, both included (a new list each call).
        Each path is walked once and kept in ``shared``: the searches ask for the same bones' paths again and
        again, in every frame the orientation tries (a horse's detection: 77k asks)."""
        cache = self.shared.setdefault("paths", {})
        nodes = cache.get((start, end))
        if nodes is None:
            nodes = [end]
            while nodes[-1] != start:
                previous = int(self.predecessors[start, nodes[-1]])
                if previous < 0:
                    raise ValueError(f"spheres {start} and {end} are not connected")
                nodes.append(previous)
            nodes = cache[(start, end)] = nodes[::-1]
        nodes = list(nodes)
        nodes[-1] = end          # the end as given, as the walk had it
        return nodes

    def moved(self, centers: np.ndarray, scale: float) -> "SphereGraph":
        """The same graph with its spheres at ``centers`` [S, 3]: a rigid motion of the old centres
        followed by a uniform ``scale``, which radii and lengths follow."""
        return SphereGraph(centers=centers, radii=self.radii * scale, edges=self.edges,
                           lengths=self.lengths * scale, distances=ScaledMatrix.of(self.distances, scale),
                           predecessors=self.predecessors, shared=self.shared)

    def path_tree(self, source: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The shortest-path tree from ``source``, each sphere's subtree as a range of a depth-first order:
        (parent [S], first [S], end [S]). Sphere w lies on the path source -> v exactly when
        first[w] <= first[v] < end[w]. Spheres that ``source`` cannot reach hang from it directly."""
        cache = self.shared.setdefault("path_trees", {})
        if source not in cache:
            from scipy.sparse import coo_matrix
            from scipy.sparse.csgraph import depth_first_order

            S = len(self.radii)
            parent = self.predecessors[source].copy()
            parent[parent < 0] = source
            parent[source] = -1
            child = np.flatnonzero(parent >= 0)
            tree = coo_matrix((np.ones(len(child)), (parent[child], child)), shape=(S, S)).tocsr()
            order = depth_first_order(tree, source, directed=True, return_predecessors=False)
            size, up = [1] * S, parent.tolist()
            for node in order[:0:-1].tolist():            # children before their parents
                size[up[node]] += size[node]
            first = np.empty(S, dtype=np.int64)
            first[order] = np.arange(S)
            cache[source] = (parent, first, first + np.array(size))
        return cache[source]

    def neighbours(self) -> list[np.ndarray]:
        """Adjacency lists: neighbours()[i] = indices of the spheres joined to sphere i."""
        if "neighbours" not in self.shared:
            out = [[] for _ in range(len(self.radii))]
            for i, j in self.edges:
                out[i].append(j)
                out[j].append(i)
            self.shared["neighbours"] = [np.array(sorted(n), dtype=np.int64) for n in out]
        return self.shared["neighbours"]


class ScaledMatrix:
    """A matrix times a uniform scale (or several, one after the other), multiplied out only where it is read:
    ``m[key]`` is ``base[key] * s1 * s2 ...`` and ``m.max(axis)`` the same of ``base.max(axis)``, the very
    numbers the scaled matrix would hold (scaling by s > 0 keeps the order, so the maxima too). The orientation
    carries the sphere graph into up to 16 candidate frames: their [S, S] distances share one matrix instead of
    a copy each (32 MB apiece at the 2,000-sphere cap)."""

    def __init__(self, base: np.ndarray, scales: tuple[float, ...]):
        self.base, self.scales = base, scales
        self.shape, self.ndim, self.dtype = base.shape, base.ndim, base.dtype

    @staticmethod
    def of(matrix, scale: float):
        """``matrix`` (an array or a ``ScaledMatrix``) times ``scale``, not multiplied out."""
        if isinstance(matrix, ScaledMatrix):
            return ScaledMatrix(matrix.base, matrix.scales + (scale,))
        return ScaledMatrix(matrix, (scale,))

    def _scaled(self, values):
        for scale in self.scales:
            values = values * scale
        return values

    def __getitem__(self, key):
        return self._scaled(self.base[key])

    def __len__(self) -> int:
        return len(self.base)

    def max(self, axis=None):
        return self._scaled(self.base.max(axis=axis))

    def __array__(self, dtype=None, copy=None):
        values = self._scaled(self.base)
        return values if dtype is None else values.astype(dtype)


def segments_inside(field: DistanceField, starts: np.ndarray, ends: np.ndarray, samples: int = 8) -> np.ndarray:
    """[N] bool: whether each segment starts[i] -> ends[i] ([N, 3] each) stays inside the mesh."""
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    points = starts[:, None, :] * (1 - t) + ends[:, None, :] * t
    depth = field.depth(points.reshape(-1, 3)).reshape(len(starts), samples)
    return np.all(depth > 0, axis=1)


def sphere_graph(field: DistanceField, spheres: Spheres) -> SphereGraph:
    """Join overlapping spheres whose connecting segment stays inside, bridge the pieces that packing left
    apart, then keep the connected part that holds the body.

    Greedy packing can leave two neighbouring spheres of a limb just short of touching, which would cut the
    limb off; each piece is therefore joined to its nearest sphere in another piece when the segment
    between them stays inside, and a piece of a limb's size that is still apart from the body then to the
    body across a gap the packing left (``_limb_pieces_to_body``). Pieces that still stand alone (an eye, a
    button, a loose accessory) carry no limb the template could use; the skin attachment still weights them.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, shortest_path
    from scipy.spatial import cKDTree

    c, r = spheres.centers, spheres.radii
    n = len(r)
    pairs = cKDTree(c).query_pairs(2 * float(r.max()), output_type="ndarray").reshape(-1, 2)
    gap = np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1)
    pairs = pairs[gap < r[pairs[:, 0]] + r[pairs[:, 1]]]
    pairs = pairs[segments_inside(field, c[pairs[:, 0]], c[pairs[:, 1]])]
    pairs = pairs[~_contacts(field, c, r, pairs)]
    pairs = _bridge_pieces(field, c, r, pairs)

    def adjacency(edges, size):
        w = np.linalg.norm(c_kept[edges[:, 0]] - c_kept[edges[:, 1]], axis=1)
        return coo_matrix((w, (edges[:, 0], edges[:, 1])), shape=(size, size)).tocsr(), w

    c_kept = c
    _, labels = connected_components(adjacency(pairs, n)[0], directed=False)
    # The piece holding the most sphere volume is the body.
    keep = np.flatnonzero(labels == int(np.argmax(np.bincount(labels, weights=r ** 3))))
    remap = np.full(n, -1)
    remap[keep] = np.arange(len(keep))
    edges = np.sort(remap[pairs[np.all(remap[pairs] >= 0, axis=1)]], axis=1)
    c_kept = c[keep]
    matrix, lengths = adjacency(edges, len(keep))
    distances, predecessors = shortest_path(matrix, directed=False, return_predecessors=True)
    return SphereGraph(centers=c_kept, radii=r[keep], edges=edges, lengths=lengths,
                       distances=distances, predecessors=predecessors)


def _bridge_pieces(field: DistanceField, c: np.ndarray, r: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``pairs`` [E, 2] plus, for each connected piece, an edge to the nearest sphere of another piece
    (nearest by the gap between the sphere surfaces) whenever that segment stays inside."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(r)
    ones = np.ones(len(pairs))
    _, labels = connected_components(coo_matrix((ones, (pairs[:, 0], pairs[:, 1])), shape=(n, n)), directed=False)
    gap = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2) - r[:, None] - r[None, :]
    gap[labels[:, None] == labels[None, :]] = np.inf
    extra = []
    for piece in unique_ints(labels):
        members = np.flatnonzero(labels == piece)
        sub = gap[members]
        least = sub.min()
        if np.isfinite(least):
            # every pair at the least gap: a symmetric body's piece on the mid-plane is as near a left sphere
            # as its mirror image, and taking the first would take the side the spheres' order puts first
            i, j = np.nonzero(sub <= least + TIE * max(abs(least), float(r.max())))
            extra.extend(sorted((int(members[a]), int(b))) for a, b in zip(i, j))
    extra = np.unique(np.array(extra, dtype=np.int64).reshape(-1, 2), axis=0)
    if len(extra):
        extra = extra[segments_inside(field, c[extra[:, 0]], c[extra[:, 1]])]
    pairs = np.vstack([pairs, extra]).astype(np.int64)
    return np.vstack([pairs, _limb_pieces_to_body(field, c, r, pairs)]).astype(np.int64)


def _limb_pieces_to_body(field: DistanceField, c: np.ndarray, r: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """[K, 2] edges joining each piece still apart from the body (the piece of the most sphere volume) after
    the first bridges, and large enough to hold a limb (its spheres' box at least ``LIMB_PIECE`` across), to
    the body's sphere nearest it: when the gap between the two is less than the smaller one's radius (a gap
    the packing left), the segment stays inside, and the surface nearest its two ends is one piece of the mesh
    and short around (within ``CONTACT_RATIO`` of the span, as ``_contacts`` asks): a thin wrist; not two
    hands held together, nor a shield or a forearm on a piece of the mesh of its own.

    The first bridges join each piece to its nearest only: a forearm and hand cut off at a thin wrist, and a
    fingertip's lone sphere nearer to them than the upper arm, were each other's nearest and stood apart from
    the body, or not, as a millionth of the height fell (makehuman_g17's left hand: its wrist 0.98 % of the
    height apart under noise). Each bound is a failure seen: bridged on between any pieces, a small piece
    between two hands held together joined them (re-posed 0 A.D. soldiers, 4.6 -> 11.1 % of the height
    worst); without the surface's test, a forearm-and-hand piece was bridged to the other hand it held (13 %
    apart under noise) and Boudicca's shield to her forearm (her left elbow 10 % of the height off); without
    the gap's, a seated spearman's spear a quarter of the height away (his right hand 43 % off)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(r)
    ones = np.ones(len(pairs))
    count, labels = connected_components(coo_matrix((ones, (pairs[:, 0], pairs[:, 1])), shape=(n, n)),
                                         directed=False)
    if count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    body = int(np.argmax(np.bincount(labels, weights=r ** 3)))
    body_index = np.flatnonzero(labels == body)
    extra = []
    for piece in unique_ints(labels):
        members = np.flatnonzero(labels == piece)
        if piece == body:
            continue
        low = (c[members] - r[members, None]).min(axis=0)
        high = (c[members] + r[members, None]).max(axis=0)
        if np.linalg.norm(high - low) < LIMB_PIECE:
            continue
        sub = np.linalg.norm(c[members][:, None, :] - c[body_index][None, :, :], axis=2) - r[members, None] \
            - r[body_index][None, :]
        least = sub.min()
        i, j = np.nonzero(sub <= least + TIE * max(abs(least), float(r.max())))
        # only a gap the packing left: less than the smaller sphere's radius
        short = sub[i, j] < np.minimum(r[members[i]], r[body_index[j]])
        extra.extend(sorted((int(members[a]), int(body_index[b]))) for a, b in zip(i[short], j[short]))
    extra = np.unique(np.array(extra, dtype=np.int64).reshape(-1, 2), axis=0)
    if len(extra):
        extra = extra[segments_inside(field, c[extra[:, 0]], c[extra[:, 1]])]
    if len(extra):
        # kept where the surface nearest both ends is one piece of the mesh and short around (a thin wrist),
        # as ``_contacts`` keeps a limb's own pinch
        mesh, piece = _surface_pieces(field.surface)
        vertex, _ = _nearest_corners(field.surface, c, unique_ints(extra.ravel()))
        a, b = vertex[extra[:, 0]], vertex[extra[:, 1]]
        span = np.linalg.norm(c[extra[:, 0]] - c[extra[:, 1]], axis=1) + r[extra[:, 0]] + r[extra[:, 1]]
        ok = piece[a] == piece[b]
        ok[ok] = ~_surface_far(mesh, a[ok], b[ok], CONTACT_RATIO * span[ok])
        extra = extra[ok]
    return extra


