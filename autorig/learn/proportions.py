"""What a template's skeleton is, learned from examples: its joints, their rest positions as statistics over
the examples in the template frame, mirror pairs, feet, fat joints, tips and helper joints.

Positions are averaged over the examples after each is brought into the template frame (``Example.prepared``)
and then made left-right symmetric, so the template is no single character's skeleton. Tips (``*_end``) are
where the limb's own surface ends: the vertex its artist weighted to the limb (the leaf joint or joints below
it) that lies farthest from the leaf joint. Joints an example lacks (a toe that a rig leaves out) are placed
as the base template places them relative to the joints around them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..template import Template
from .examples import Example

MIRROR_TOLERANCE = 0.03   # template units: a joint's mirror image lies this close to its mirror partner
FOOT_HEIGHT = 0.06        # template units: leaves this low (on average) are feet
FAT_DEPTH = 0.6           # a branch joint at least this deep (relative to the deepest joint) is fat
TIP = "_end"


@dataclass
class Skeleton:
    """The joints a learned template has.

    names     [J] template joint names (tips end in ``_end``)
    parents   [J] parent index, -1 for the root, parents first
    source    [J] the example joint name each template joint is, None for tips added by the learner
    helpers   [(name, parent template index)] weightless example joints that ride along
    """
    names: list[str]
    parents: np.ndarray
    source: list[str | None]
    helpers: list[tuple[str, int]]


def skeleton_of_base(base: Template) -> Skeleton:
    """The base template's own joints (corpus examples name them through their maps)."""
    return Skeleton(list(base.names), base.parents.copy(),
                    [None if base.is_tip(j) else n for j, n in enumerate(base.names)], [])


def skeleton_of_examples(examples: list[Example]) -> Skeleton:
    """The joints of rigged glTF examples sharing one skeleton: every joint that carries weight in some
    example and its ancestors, in the examples' hierarchy, plus a tip beyond every weighted leaf; the joints
    that carry no weight in any example (IK targets, prop sockets) become helpers."""
    first = examples[0]
    common = [n for n in first.names if all(n in e.key_of for e in examples)]
    if len(common) < 2:
        raise InputError("the rigged examples share fewer than two joint names: are they one skeleton?")
    # A joint that carries weight in a few examples only holds their props (a shield, a sword): a helper.
    carrying = {n for n in common
                if 2 * sum(e.weights[:, e.key_of[n]].max() > 1e-6 for e in examples) >= len(examples)}
    if not carrying:
        raise InputError("no joint carries weight in the rigged examples")
    parent_of = {n: (first.names[first.parents[first.key_of[n]]] if first.parents[first.key_of[n]] >= 0
                     else None) for n in common}
    kept = set()
    for n in carrying:
        # An ancestor some examples lack is no joint of the shared skeleton: the walk stops below it.
        while n in parent_of and n not in kept:
            kept.add(n)
            n = parent_of[n]
    roots = [n for n in kept if parent_of[n] is None or parent_of[n] not in kept]
    if len(roots) != 1:
        raise InputError(f"the weighted joints of the examples hang from {len(roots)} roots ({sorted(roots)}); "
                         "a template needs one")
    order, frontier = [], [roots[0]]
    while frontier:                                   # parents first, in the file's joint order
        n = frontier.pop(0)
        order.append(n)
        frontier.extend(c for c in common if c in kept and parent_of[c] == n)
    names, source = list(order), list(order)
    parents = [order.index(parent_of[n]) if parent_of[n] in kept else -1 for n in order]
    tips = set()
    for j, n in enumerate(order):
        if n in carrying and not any(parent_of[c] == n for c in kept):
            # A weightless "_end" child the file already has is the tip; otherwise the learner adds one.
            own = [c for c in common if parent_of[c] == n and c.endswith(TIP)
                   and not any(parent_of[d] == c for d in common)]
            names.append(own[0] if own else n + TIP)
            source.append(own[0] if own else None)
            parents.append(j)
            tips.update(own[:1])
    helpers = []
    for n in common:
        if n in kept or n in tips:
            continue
        p = parent_of[n]
        while p is not None and p not in kept:
            p = parent_of.get(p)
        helpers.append((n, names.index(p) if p is not None else 0))
    return Skeleton(names, np.array(parents, dtype=np.int64), source, helpers)


def example_positions(example: Example, skeleton: Skeleton, base: Template | None) -> np.ndarray:
    """[J, 3] the example's skeleton in the template frame: its own joints, tips where its limbs end, and
    the joints it lacks placed as ``base`` places them (see the module docstring)."""
    J = len(skeleton.names)
    canonical = example.canonical_joints()
    positions = np.full((J, 3), np.nan)
    for j, n in enumerate(skeleton.source):
        if n is not None and n in example.key_of:
            positions[j] = canonical[example.key_of[n]]
    for j, n in enumerate(skeleton.names):
        if skeleton.source[j] is None and skeleton.parents[j] >= 0:
            positions[j] = _tip(example, skeleton, j, positions)
    return _fill_missing(positions, skeleton, base)


def _tip(example: Example, skeleton: Skeleton, tip: int, positions: np.ndarray) -> np.ndarray:
    """Where the limb ending at ``tip``'s parent ends: the farthest vertex weighted to that joint of the
    example, or to joints below it that stand for no other template joint."""
    j = int(skeleton.parents[tip])
    if skeleton.source[j] is None or skeleton.source[j] not in example.key_of:
        # The limb's last joint is missing (a rig without toes): its tip is placed with it, as the base does.
        return np.full(3, np.nan)
    own = example.key_of[skeleton.source[j]]
    others = {example.key_of[n] for n in skeleton.source if n is not None and n in example.key_of} - {own}
    below = [k for k in example.descendants(own) if k not in others]
    dominant = np.argmax(example.weights, axis=1)
    vertices = example.prepared().vertices[np.isin(dominant, below)]
    if len(vertices) == 0:
        return np.full(3, np.nan)
    anchor = positions[j]
    return vertices[int(np.argmax(np.linalg.norm(vertices - anchor, axis=1)))]


def _fill_missing(positions: np.ndarray, skeleton: Skeleton, base: Template | None) -> np.ndarray:
    """Joints without a position placed like the base template places them between their nearest known
    ancestor and descendant (or at the base's offset from the ancestor)."""
    missing = np.flatnonzero(np.isnan(positions[:, 0]))
    if len(missing) == 0:
        return positions
    if base is None:
        return positions          # the learner places them from the other examples (``fill_from_others``)
    ref = {n: base.positions[i] for i, n in enumerate(base.names)}
    children = [np.flatnonzero(skeleton.parents == j) for j in range(len(skeleton.names))]
    known = ~np.isnan(positions[:, 0])
    out = positions.copy()
    for m in missing:                                  # parents first: ancestors are filled before
        a = int(skeleton.parents[m])
        if a < 0:
            raise InputError(f"an example has no {skeleton.names[m]} joint, the template's root")
        b, frontier = None, list(children[m])
        while frontier and b is None:                  # the nearest known joint below, breadth first
            c = int(frontier.pop(0))
            b = c if known[c] else None
            frontier.extend(children[c])
        base_a, base_m = ref[skeleton.names[a]], ref[skeleton.names[m]]
        if b is None:
            out[m] = out[a] + (base_m - base_a)
            continue
        base_b = ref[skeleton.names[b]]
        axis = base_b - base_a
        t = float((base_m - base_a) @ axis / max(axis @ axis, 1e-12))
        residual = base_m - (base_a + t * axis)
        ratio = np.linalg.norm(out[b] - out[a]) / max(np.linalg.norm(axis), 1e-12)
        out[m] = out[a] + t * (out[b] - out[a]) + residual * ratio
    return out


def fill_from_others(per_example: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """[N, J, 3] with every joint an example could not place (NaN) at the mean offset from its parent over the
    examples that could (a tip whose limb has no vertex of its own in one example)."""
    out = per_example.copy()
    for j in range(out.shape[1]):                 # parents first
        missing = np.isnan(out[:, j, 0])
        if not missing.any():
            continue
        p = parents[j]
        if missing.all() or p < 0:
            raise InputError("no example places the joint " + str(j))
        offset = np.mean(out[~missing, j] - out[~missing, p], axis=0)
        out[missing, j] = out[missing, p] + offset
    return out


def mirror_pairs(positions: np.ndarray, parents: np.ndarray) -> list[tuple[int, int]]:
    """(left, right) joint pairs whose positions [J, 3] mirror each other across x = 0 (left at +x), with
    mirrored (or shared) parents: the same rule for every skeleton, whatever its joints are called."""
    flipped = positions * [-1.0, 1.0, 1.0]
    pairs: dict[int, int] = {}
    for i in range(len(positions)):                       # parents first: a pair's parents are paired before it
        if positions[i, 0] <= 1e-3 or i in pairs:           # a joint on the mid-plane is its own mirror
            continue
        d = np.linalg.norm(positions - flipped[i], axis=1)
        d[[i, *pairs]] = np.inf
        j = int(np.argmin(d))
        if d[j] > MIRROR_TOLERANCE:
            continue
        pi, pj = int(parents[i]), int(parents[j])
        if pi == pj or pairs.get(pi) == pj:
            pairs[i], pairs[j] = j, i
    return sorted((i, j) for i, j in pairs.items() if positions[i, 0] > 0)


def symmetrized(positions: np.ndarray, pairs: list[tuple[int, int]]) -> np.ndarray:
    """[J, 3] ``positions`` made exactly left-right symmetric: pairs averaged with each other's mirror image,
    the other joints within MIRROR_TOLERANCE of the mid-plane put on it (x = 0)."""
    out = positions.copy()
    flip = np.array([-1.0, 1.0, 1.0])
    paired = set()
    for i, j in pairs:
        mean = (positions[i] + positions[j] * flip) / 2
        out[i], out[j] = mean, mean * flip
        paired |= {i, j}
    central = [k for k in range(len(out)) if k not in paired and abs(out[k, 0]) < MIRROR_TOLERANCE]
    out[central, 0] = 0.0
    return out


def feet(positions: np.ndarray, parents: np.ndarray) -> list[int]:
    """The leaves that stand on the ground: ends of chains lower than ``FOOT_HEIGHT``."""
    leaves = [j for j in range(len(parents)) if j not in set(parents.tolist())]
    return [j for j in leaves if positions[j, 1] <= FOOT_HEIGHT]


def fat_joints(depths: np.ndarray, parents: np.ndarray, tips: np.ndarray) -> list[int]:
    """The root and branch joints whose mean depth [J] (distance to the surface, template units) is at least
    ``FAT_DEPTH`` of the deepest joint's: the ones in the body's thickest parts."""
    children = np.bincount(parents[parents >= 0], minlength=len(parents))
    branch = [j for j in range(len(parents)) if (parents[j] < 0 or children[j] >= 2) and not tips[j]]
    deepest = float(np.max(depths[~tips])) if (~tips).any() else 0.0
    return [j for j in branch if deepest > 0 and depths[j] >= FAT_DEPTH * deepest]
