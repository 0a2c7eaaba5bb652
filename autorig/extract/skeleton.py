"""Stage 5 of the template-free skeleton: the control skeleton (Wade & Parent 2002, section 5).

Each path of the path tree becomes one chain of joints. A chain always has joints at its two ends and where
later paths join it, and one at its limb's base (where the limb leaves the body: the crossing of the body
before it is one bone) when that is at least the shortest bone from the joints around it and the budget
allows. Beyond the base it is split recursively where a straight bone would fit it worst: the split point is
the path point that gives the smallest maximum error of the two bones it makes (the error of a bone being the
largest distance of the path points it replaces from it), which on a single bend is the bend, among the
points at least the shortest bone (MIN_BONE_*: relative to the limb's thickness, its length and the shape's
diagonal) from both ends. The bone with the largest error is split first, until every bone's error is below
SPLIT_TOLERANCE times the mean depth of its stretch of path, or of THINNEST_DEPTH voxels if that is more (a
bend shallower than that is not worth a joint, so a straight limb keeps its base and its tip) or ``max_segments`` - 1 splits have been made: a chain has at
most ``max_segments`` bones plus one more for each joint where another chain hangs.

Names are generated and stable: ``root`` (the heart), then for chain c (numbered from 1 in the order the
paths were grown: farthest extreme point first) ``chain<c>_joint1``, ``chain<c>_joint2``, ... outward, and
``chain<c>_end`` for its last joint when nothing hangs from it: a tip that carries no bone, as ``_end`` joints
do in the templates.
"""
from __future__ import annotations

import numpy as np

from ..template import Template
from .paths import PathTree
from .voxels import VoxelGrid

SPLIT_TOLERANCE = 0.5
# A path along a limb a voxel or two thick zigzags by about a voxel however straight the limb: measured
# against at least this depth (voxels), that is no bend.
THINNEST_DEPTH = 3.0
# The shortest bone a split may make: a bone shorter than its limb is thick, or than a small share of the
# limb's length or of the whole shape, is a knot, not a joint a rigger would place.
MIN_BONE_DEPTHS = 2.0      # times the limb's mean depth (its radius)
MIN_BONE_LENGTH = 0.15     # of the limb's length from its base to its tip
MIN_BONE_DIAGONAL = 0.025  # of the diagonal of the mesh's bounding box
# A split joint sits at the soft minimum of the split error (``soft_split``): split points whose error is this
# much (voxels) more than the least weigh 1/e as much as the best.
SOFT_ERROR = 0.5


def control_skeleton(tree: PathTree, grid: VoxelGrid, max_segments: int) -> tuple[np.ndarray, Template]:
    """Joints [J, 3] (canonical frame) and the generated template (names, parents; no symmetry, feet or fat)
    of the control skeleton of ``tree`` (voxel units of ``grid``), at most ``max_segments`` (>= 1) bones per
    chain plus one for each joint where another chain hangs."""
    if max_segments < 1:
        raise ValueError(f"max_segments must be at least 1, got {max_segments}")
    attached = np.zeros(len(tree.points), dtype=bool)
    attached[[int(p[0]) for p in tree.paths]] = True
    diagonal = grid.diagonal
    joint_of = {0: 0}                                         # tree point -> joint index
    names, parents, points, chain_ends = ["root"], [-1], [tree.points[0]], []
    for c, (path, base) in enumerate(zip(tree.paths, tree.bases), start=1):
        limb = tree.points[path[base:]]
        min_bone = max(MIN_BONE_DIAGONAL * diagonal, MIN_BONE_DEPTHS * float(tree.depth[path[base:]].mean()),
                       MIN_BONE_LENGTH * float(np.linalg.norm(np.diff(limb, axis=0), axis=1).sum()))
        keep = split_chain(tree.points[path], tree.depth[path], np.flatnonzero(attached[path]), max_segments,
                           base, min_bone)
        previous = joint_of[int(path[0])]
        fixed = {0, len(path) - 1, base, *map(int, np.flatnonzero(attached[path]))}
        for k, i in enumerate(keep[1:], start=1):
            joint_of[int(path[i])] = len(names)
            names.append(f"chain{c}_joint{k}")
            parents.append(previous)
            point = None if i in fixed else soft_split(tree.points[path], int(keep[k - 1]), int(keep[k + 1]),
                                                       min_bone, base + 1)
            points.append(tree.points[path[i]] if point is None else point)
            previous = len(names) - 1
        chain_ends.append((c, previous))
    parents = np.array(parents, dtype=np.int64)
    for c, j in chain_ends:
        if not np.any(parents == j):
            names[j] = f"chain{c}_end"
    joints = grid.centres(np.array(points))
    template = Template(name="auto", names=tuple(names), parents=parents, positions=joints, symmetry=(),
                        feet=(), fat=())
    return joints, template


def split_chain(points: np.ndarray, depth: np.ndarray, forced: np.ndarray, max_segments: int, base: int = 0,
                min_bone: float = 0.0) -> np.ndarray:
    """Indices [S + 1] (ascending, first and last included) of the joints of a chain along a path.

    points [n, 3] the path, depth [n] its EDM, forced [F] indices that must be joints (where other chains
    hang), base the index where the limb leaves the body (a joint too when the budget allows, and the body
    crossed before it gets no joint of its own), min_bone the shortest bone a split may make (the base is
    left out when it is that close to another joint); see the module docstring for the rule.
    """
    end = len(points) - 1
    keep = sorted({0, end, *map(int, forced)})
    budget = len(keep) - 1 + max_segments - 1                 # the forced joints do not use up the budget
    gaps = np.linalg.norm(points[keep] - points[base], axis=1)
    if 0 < base < end and len(keep) - 1 < budget and gaps.min() >= min_bone:
        keep = sorted({*keep, base})
    too_short: set[tuple[int, int]] = set()                  # bones with no split point min_bone from both ends
    while len(keep) - 1 < budget:
        # Each bone's error in units of the depth along it: how far the path strays, for the limb's size.
        scores = [segment_error(points, a, b) / max(float(depth[a:b + 1].mean()), THINNEST_DEPTH)
                  if b > base + 1 and (a, b) not in too_short else 0.0 for a, b in zip(keep[:-1], keep[1:])]
        worst = int(np.argmax(scores))
        a, b = keep[worst], keep[worst + 1]
        if scores[worst] <= SPLIT_TOLERANCE:
            break
        k = best_split(points, a, b, min_bone, first=base + 1)
        if k is None:
            too_short.add((a, b))
            continue
        keep.insert(worst + 1, k)
    return np.array(keep, dtype=np.int64)


def segment_error(points: np.ndarray, a: int, b: int) -> float:
    """Largest distance of points[a..b] from the straight bone points[a] -> points[b]."""
    return float(_distances_to_segment(points[a:b + 1], points[a], points[b]).max())


def best_split(points: np.ndarray, a: int, b: int, min_bone: float = 0.0, first: int = 0) -> int | None:
    """The index k in (a, b) that minimises max(error of bone a -> k, error of bone k -> b), among those at
    least min_bone from both ends and not before ``first`` (None if there is none)."""
    worst, allowed = split_errors(points, a, b, min_bone, first)
    if not allowed.any():
        return None
    return a + int(np.argmin(np.where(allowed, worst, np.inf)))


def split_errors(points: np.ndarray, a: int, b: int, min_bone: float = 0.0,
                 first: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(worst [b - a + 1]: max(error of bone a -> k, error of bone k -> b) for each k in a..b, allowed
    [b - a + 1]: the k at least min_bone from both ends, strictly between them and not before ``first``)."""
    q = points[a:b + 1]
    m = len(q)
    # head[i, k]: distance of point i from the bone a -> k, counted for i <= k; tail likewise for k -> b.
    head = _distance_matrix(q, q[0], q)
    tail = _distance_matrix(q, q, q[-1])
    i, k = np.arange(m)[:, None], np.arange(m)[None, :]
    worst = np.maximum(np.where(i <= k, head, 0.0).max(axis=0), np.where(i >= k, tail, 0.0).max(axis=0))
    allowed = (np.linalg.norm(q - q[0], axis=1) >= min_bone) & (np.linalg.norm(q - q[-1], axis=1) >= min_bone)
    allowed[[0, -1]] = False
    allowed[:max(first - a, 0)] = False
    return worst, allowed


def soft_split(points: np.ndarray, a: int, b: int, min_bone: float = 0.0, first: int = 0) -> np.ndarray | None:
    """The joint between bones a -> . -> b placed by a soft minimum of the split error along the path: the
    point at the weighted mean arc length of the allowed split points (``split_errors``), each weighted by
    exp(-(its error - the least) / SOFT_ERROR). Where two split points fit almost equally well (a straight
    stretch, a gentle bend), the least change of the path would flip the best one; this moves only a little.
    None when no split point is allowed."""
    worst, allowed = split_errors(points, a, b, min_bone, first)
    if not allowed.any():
        return None
    q = points[a:b + 1]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    weight = np.where(allowed, np.exp(-(worst - worst[allowed].min()) / SOFT_ERROR), 0.0)
    t = float(weight @ arc / weight.sum())
    return np.array([np.interp(t, arc, q[:, c]) for c in range(3)])


def _distances_to_segment(x: np.ndarray, head: np.ndarray, tail: np.ndarray) -> np.ndarray:
    """Distances [m] of points x [m, 3] from the segment head -> tail ([3] each)."""
    e = tail - head
    t = np.clip((x - head) @ e / max(float(e @ e), 1e-12), 0.0, 1.0)
    return np.linalg.norm(x - head - t[:, None] * e, axis=1)


def _distance_matrix(x: np.ndarray, heads: np.ndarray, tails: np.ndarray) -> np.ndarray:
    """[m, K] distance of each point x [m, 3] from each segment heads[k] -> tails[k] (each [3] or [K, 3])."""
    heads = np.broadcast_to(heads, (len(x), 3)) if np.ndim(heads) == 1 else heads
    tails = np.broadcast_to(tails, (len(x), 3)) if np.ndim(tails) == 1 else tails
    e = tails - heads                                                        # [K, 3]
    ee = np.maximum(np.einsum("kj,kj->k", e, e), 1e-12)
    rel = x[:, None, :] - heads[None, :, :]                                  # [m, K, 3]
    t = np.clip(np.einsum("mkj,kj->mk", rel, e) / ee, 0.0, 1.0)
    return np.linalg.norm(rel - t[..., None] * e[None, :, :], axis=2)
