"""Stage 4 of the template-free skeleton: the path tree (Wade & Parent 2002, section 4).

On the connected DMS (``connect.connected_medial``):

* the heart is the most central voxel: the deepest one (largest EDM). A uniform tube has a run of equally deep
  voxels, so among the voxels within one voxel of the largest depth the one nearest their mean is taken
  (``connect.most_central``);
* extreme points are the local maxima of the geodesic distance from the heart over the DMS (Dijkstra with
  Euclidean edge lengths: the paper's breadth-first search without the 26-neighbourhood's diagonal bias),
  tried farthest first;
* each extreme point grows a centralised path back to the tree: the route minimising W = sum of 1/d^3 over its
  voxels (d the EDM), which keeps to the middle of the volume. The first path, from the farthest extreme
  point, runs to the heart and is always kept (so a limbless blob still gets one bone);
* the voxels of a path cover the DMS voxels inside their inscribed balls (radius = their EDM). A path's limb
  base (``limb_base``) is where it leaves the body: past the voxels the tree already covers, and past those
  whose balls lie inside the ball of one of its own voxels BODY_DEPTH times deeper than the limb beyond (the
  body it crosses on the way out). An extreme point is not used when its path reaches less than NOISE_LENGTH times the limb's own
  greatest depth beyond its base, or less than MIN_REACH voxels (Wade & Parent's noise threshold, scaled by
  the local thickness where the limb attaches rather than by the body's): it is a bump, a flat rim of the
  part it sits on, or a ripple of the voxelization, not a limb. Nor is one whose reach is less than
  LIMB_SHARE of the longest way out from where it would hang, along the paths kept so far (from the heart:
  the longest limb; from a point on a limb: the rest of that limb or of its longest branch): a branch that
  short beside the others is a bump on the part it leaves, as a spider's fangs and palps beside its legs. The
  test is a ratio of lengths, so it does not depend on the mesh's units or the voxels' size, and each branch
  tried is kept with its share (``Candidate``) for the confidence (``confidence``);
* a path that would join the tree where an earlier path crosses the body (before that path's base) hangs
  from where that path starts instead (the heart, or a joint on a limb), so the body holds no joints of its
  own; one that would join within the inscribed ball of an existing branch point (or limb base) joins there,
  so limbs leaving close together share one joint rather than leaving a string of tiny bones;
* the paths, jagged from the voxel steps, are smoothed with their ends held fixed, each point staying inside
  the inscribed ball of its voxel.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from ..errors import RigFailedError
from .connect import VoxelGraph, most_central

NOISE_LENGTH = 1.5       # a limb reaches beyond the covered part at least this many depths of where it joins
MIN_REACH = 4.5          # ... and at least this many voxels
BODY_DEPTH = 1.5         # a limb's path crosses the body where it is this many times deeper than the limb
SMOOTH_ITERATIONS = 8    # passes of (1/4, 1/2, 1/4) averaging along each path
BALL_FRACTION = 0.9      # smoothing moves a point by at most this fraction of its depth
# A branch is a limb when it reaches at least this share of the longest way out from where it hangs (see
# ``grow_paths``). Learned on labelled shapes (benchmarks/limb_share.py): the shortest limb of 200 random
# creatures reaches 0.335 of it; the spider's longest palp 0.22 at 96 voxels and 0.27 at 64, its shortest leg
# 0.75; the octopus's shortest arm 0.47. Set between the closest two (0.27, 0.335), as far (in ratio) from each.
LIMB_SHARE = 0.30
# How much nearer an extreme point on the left counts, per voxel of its offset from the middle (see
# ``extreme_points``): more than the float noise between mirror-symmetric limbs (the voxel grid is symmetric
# about the middle), too little to reorder limbs that differ at all (0.1 swapped the armadillo's tail and ear).
SIDE_TILT = 0.01


class Candidate(NamedTuple):
    """An extreme point tried as a limb: its node, its reach beyond its base (voxels), that reach's share of
    the longest way out from where it would hang, whether the noise test dropped it as a ripple, whether it was
    kept."""
    tip: int
    reach: float
    share: float
    ripple: bool
    kept: bool


@dataclass(frozen=True)
class PathTree:
    """The tree of centralised paths, in voxel units.

    points  [P, 3] float64 positions of the tree's points (grid coordinates, smoothed); point 0 is the heart
    depth   [P] EDM at each point (voxels)
    paths   [K] int64 arrays of point indices: path k runs from the point where it joins the tree (the heart or
            a point of an earlier path) out to its extreme point; paths in the order they were grown
    bases   [K] for each path, the index in it of its limb's base: the first point outside the parts grown
            before it (the body, for a limb leaving the body); before it the path only crosses the body
    """
    points: np.ndarray
    depth: np.ndarray
    paths: list[np.ndarray]
    bases: list[int]
    candidates: list[Candidate] = field(default_factory=list)


def path_tree(graph: VoxelGraph) -> PathTree:
    """Grow the path tree on the connected DMS ``graph`` (see ``connect.connected_medial``)."""
    lengths = graph.matrix(graph.lengths)
    heart = most_central(graph, np.arange(len(graph.voxels)))
    geodesic = dijkstra(lengths, indices=heart)
    extremes = extreme_points(graph, geodesic)
    if len(extremes) == 0:
        raise RigFailedError(f"the shape's medial surface is {len(graph.voxels)} voxel(s) across, too small to "
                             f"grow a skeleton on: use more voxels")
    paths, bases, candidates = grow_paths(graph, heart, extremes)
    return smooth_tree(graph, heart, paths, bases, candidates)


def extreme_points(graph: VoxelGraph, geodesic: np.ndarray) -> np.ndarray:
    """Nodes [K] whose geodesic distance from the heart (geodesic [N]) is at least their every neighbour's,
    farthest first, the heart left out. The order is by the distance plus SIDE_TILT times the node's offset to
    the left of the middle of the DMS (then by node index): a mirror-symmetric pair of limbs is as far on both
    sides, up to the noise of the voxels, and would otherwise be taken in an order that the least change of the
    mesh flips (which horn a cow's head path runs to, which ear gets the lower chain number)."""
    a, b = graph.edges.T
    beaten = np.zeros(len(geodesic), dtype=bool)
    beaten[a[geodesic[b] > geodesic[a]]] = True
    beaten[b[geodesic[a] > geodesic[b]]] = True
    beaten[geodesic == 0] = True
    candidates = np.flatnonzero(~beaten)
    x = graph.voxels[candidates, 0].astype(np.float64)
    middle = 0.5 * float(graph.voxels[:, 0].min() + graph.voxels[:, 0].max())
    return candidates[np.lexsort((candidates, -(geodesic[candidates] + SIDE_TILT * (x - middle))))]


def grow_paths(graph: VoxelGraph, heart: int, extremes: np.ndarray) -> tuple[list[np.ndarray], list[int],
                                                                           list[Candidate]]:
    """Centralised paths [K] (node index arrays, from the tree out to the extreme point) of the extreme points
    (extremes [E], in the order to try them) that pass the coverage test, and each one's base: the index in it
    where the limb leaves the parts already in the tree (see the module docstring)."""
    costs = graph.matrix(graph.centralised_costs())
    balls = cKDTree(graph.voxels)
    in_tree = np.zeros(len(graph.voxels), dtype=bool)
    in_tree[heart] = True
    covered = np.zeros(len(graph.voxels), dtype=bool)
    covered[_covered_by(balls, graph, np.array([heart]))] = True
    branch_points = [heart]
    paths: list[np.ndarray] = []
    bases: list[int] = []
    candidates: list[Candidate] = []
    body_of = np.full(len(graph.voxels), -1, dtype=np.int64)   # node -> the path whose body part holds it
    # beyond[n]: the longest way from node n out to a tip along the kept paths (for a node in the body a path
    # crosses, that path's whole limb): what a new branch hanging at n is measured against.
    beyond = np.zeros(len(graph.voxels))
    route = None
    for tip in extremes:
        # The farthest extreme point always grows a path, so that even a limbless blob gets one bone.
        if paths and covered[tip]:
            continue
        if route is None:
            _, route, _ = dijkstra(costs, indices=np.flatnonzero(in_tree), min_only=True, return_predecessors=True)
        path = _walk(route, tip)[::-1]                        # from the tree out to the tip
        base = limb_base(graph, path, covered[path])
        # Its own thickness beyond the body, not the body's where the path joins, says whether it stands out.
        steps = np.linalg.norm(np.diff(graph.voxels[path[base:]], axis=0), axis=1)
        reach = float(steps.sum())
        rerouted = body_of[path[0]] >= 0
        # It joins an earlier path inside the body that path crosses: it hangs where that path starts (the
        # heart, or a joint of a limb), not from a joint of its own in the middle of the body.
        hang = int(paths[body_of[path[0]]][0]) if rerouted else \
            _snap(graph, path[0], np.array(branch_points)) if paths else int(path[0])
        if paths:
            # A ripple: shorter than its own thickness, or than a few voxels. Else a limb if it stands out
            # against the longest way out from where it hangs: a bump does not, whatever the scale.
            ripple = reach < max(NOISE_LENGTH * graph.depth[path[base:]].max(), MIN_REACH)
            share = reach / max(float(beyond[hang]), 1e-9)
            kept = not ripple and share >= LIMB_SHARE
            candidates.append(Candidate(int(tip), reach, share, ripple, kept))
            if not kept:
                continue
        if rerouted:
            path = np.concatenate([[hang], path[max(base, 1):]])
            base = 1
        else:
            path[0] = hang
        branch_points += [int(path[0]), int(path[base])]
        body_of[path[1:base]] = len(paths)
        paths.append(path)
        bases.append(base)
        in_tree[path] = True
        covered[_covered_by(balls, graph, path)] = True
        _extend_beyond(beyond, graph, path, base)
        route = None                                         # the tree has changed: recompute when needed
    return paths, bases, candidates


def _extend_beyond(beyond: np.ndarray, graph: VoxelGraph, path: np.ndarray, base: int) -> None:
    """Raise beyond [N] along a newly kept path [L] (base: where its limb leaves the body) to the length of the
    way from each of its nodes out to its tip: the limb's whole reach for the nodes before its base."""
    steps = np.linalg.norm(np.diff(graph.voxels[path], axis=0), axis=1)
    remaining = np.concatenate([np.cumsum(steps[::-1])[::-1], [0.0]])
    remaining[:base] = remaining[base]
    beyond[path] = np.maximum(beyond[path], remaining)


def limb_base(graph: VoxelGraph, path: np.ndarray, covered: np.ndarray) -> int:
    """The index in path [L] (nodes, from the tree out to a tip; covered [L]: inside the balls of the tree so
    far) where its limb leaves the body: past the voxels the tree covers, and past the voxels whose inscribed
    balls lie inside the ball of one of the path's voxels BODY_DEPTH times deeper than the limb (the median
    depth beyond the tree) and a voxel more: that is the body it crosses on the way out. Never the tip."""
    first = int(np.argmin(covered))
    depth = graph.depth[path]
    # A voxel more than the limb's depth (and one voxel of noise) deeper: on a limb a voxel or two thick, the
    # voxelization's ripples alone make some voxels half again as deep as the rest.
    thick = np.flatnonzero(depth > BODY_DEPTH * np.median(depth[first:]) + 1.0)
    if len(thick):
        points = graph.voxels[path].astype(np.float64)
        gap = np.linalg.norm(points[first:, None] - points[None, thick], axis=2)          # [L - first, T]
        inside = np.flatnonzero((gap + depth[first:, None] <= depth[thick][None]).any(axis=1))
        if len(inside):
            first += int(inside.max()) + 1
    return min(first, len(path) - 2) if len(path) > 1 else 0


def _covered_by(balls: cKDTree, graph: VoxelGraph, nodes: np.ndarray) -> np.ndarray:
    """Nodes inside the inscribed balls of nodes [K] (centre: the voxel, radius: its depth)."""
    hits = balls.query_ball_point(graph.voxels[nodes], r=graph.depth[nodes])
    return np.concatenate([np.asarray(h, dtype=np.int64) for h in hits])


def _walk(pred: np.ndarray, node: int) -> np.ndarray:
    """Nodes [L] of the Dijkstra predecessor chain pred [N] from node back to its source."""
    chain = [node]
    while pred[chain[-1]] >= 0:
        chain.append(int(pred[chain[-1]]))
    return np.array(chain, dtype=np.int64)


def _snap(graph: VoxelGraph, node: int, branch_points: np.ndarray) -> int:
    """The branch point nearest to node if it lies within node's inscribed ball, else node itself."""
    gap = np.linalg.norm(graph.voxels[branch_points] - graph.voxels[node], axis=1)
    k = int(np.argmin(gap))
    return int(branch_points[k]) if gap[k] <= graph.depth[node] else node


def smooth_tree(graph: VoxelGraph, heart: int, paths: list[np.ndarray], bases: list[int],
                candidates: list[Candidate] | None = None) -> PathTree:
    """Renumber the tree's nodes (heart first, then each path's new nodes in order) and smooth every path with
    its ends held fixed (SMOOTH_ITERATIONS passes of (1/4, 1/2, 1/4) averaging), no point moving further than
    BALL_FRACTION of its depth from its voxel's centre."""
    order = np.concatenate([[heart]] + [p[1:] for p in paths]).astype(np.int64)
    index = np.full(len(graph.voxels), -1, dtype=np.int64)
    index[order] = np.arange(len(order))
    centres = graph.voxels[order].astype(np.float64)
    # The inscribed ball of a voxel (radius: its depth, an exact distance to the surface) is inside the solid;
    # keeping every point within BALL_FRACTION of its own keeps the smoothed paths inside thin bent limbs.
    reach = BALL_FRACTION * graph.depth[order]
    points = centres.copy()
    tree_paths = [index[p] for p in paths]
    # The base is held too: the crossing of the body before it is one straight bone, whose far end (a rerouted
    # path's jump from where it hangs) must not drag the limb's first joint back into the body.
    for piece in [part for path, base in zip(tree_paths, bases) for part in (path[:base + 1], path[base:])]:
        q, home, limit = points[piece], centres[piece[1:-1]], reach[piece[1:-1], None]
        for _ in range(SMOOTH_ITERATIONS if len(piece) > 2 else 0):
            moved = 0.25 * q[:-2] + 0.5 * q[1:-1] + 0.25 * q[2:] - home
            length = np.linalg.norm(moved, axis=1, keepdims=True)
            q[1:-1] = home + moved * np.minimum(1.0, limit / np.maximum(length, 1e-12))
        points[piece[1:-1]] = q[1:-1]
    return PathTree(points, graph.depth[order], tree_paths, list(bases), list(candidates or []))
