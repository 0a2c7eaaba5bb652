"""Examples with other proportions: each example's mesh re-proportioned through its own artist's skin weights.

Every corpus character of one kind shares one skeleton, so the rigs the confidence is calibrated on all have
the proportions of that skeleton. A character from elsewhere (longer legs, a bigger head, shorter arms) then
reads as "far from the learned proportions", and the confidence cannot know whether that makes its rig wrong.
These variants show it: the same character with each template bone lengthened or shortened and its end parts
(head, hands) grown or shrunk, mirror pairs alike, rigged with the true skeleton known exactly.

The mesh follows the skeleton by linear blend skinning with the artist's weights: joint k's transform moves
its rest position to the new one and stretches its region along its bone by the bone's factor (or scales an
end part uniformly about its joint), and every vertex takes its weighted blend.
"""
from __future__ import annotations

import zlib
from dataclasses import replace

import numpy as np

from ..template import Template
from .examples import Example
from .proportions import Skeleton

BONE_RANGE = 1.3     # each bone's length factor is log-uniform in [1 / BONE_RANGE, BONE_RANGE]
END_RANGE = 1.3      # ... and each end part's size (head, hands; not feet), likewise
VARIANTS = 2         # re-proportioned variants of each example


def varied(example: Example, skeleton: Skeleton, template: Template, variant: int) -> Example:
    """``example`` re-proportioned with factors drawn for ``variant`` (deterministic per example name and
    variant): the same faces and weights, new vertices [V, 3] and joint positions [J, 3]."""
    rng = np.random.default_rng([zlib.crc32(example.name.encode()), variant])
    J = len(skeleton.names)
    bone = np.exp(rng.uniform(-1, 1, J) * np.log(BONE_RANGE))
    end = np.exp(rng.uniform(-1, 1, J) * np.log(END_RANGE))
    for left, right in template.symmetry:
        bone[right], end[right] = bone[left], end[left]
    factor = np.ones(len(example.names))        # per example joint: its incoming bone's length factor
    size = np.zeros(len(example.names))         # per example joint: uniform scale of an end part (0: none)
    # A foot (or the joint its tip hangs from) keeps its size: the character still stands on the same soles.
    grounded = set(template.feet) | {int(skeleton.parents[f]) for f in template.feet}
    for j, name in enumerate(skeleton.source):
        if name is None or name not in example.key_of:
            continue
        k = example.key_of[name]
        if skeleton.parents[j] >= 0:
            factor[k] = bone[j]
        children = np.flatnonzero(skeleton.parents == j)
        if all(template.is_tip(int(c)) for c in children) and j not in grounded and skeleton.parents[j] >= 0:
            for d in example.descendants(k):
                size[d] = end[j]
    return _reproportioned(example, factor, size, variant)


def _reproportioned(example: Example, factor: np.ndarray, size: np.ndarray, variant: int) -> Example:
    """The example with each joint's incoming bone [J] scaled by ``factor`` and the parts with ``size`` [J] > 0
    scaled uniformly by it (about their top joint; descendants share it)."""
    old = example.positions
    new = old.copy()
    for k in _parents_first(example.parents):
        p = example.parents[k]
        if p >= 0:
            scale = size[k] if size[k] > 0 and size[p] > 0 else factor[k]
            new[k] = new[p] + scale * (old[k] - old[p])
    transforms = np.repeat(np.eye(3)[None], len(old), axis=0)
    for k in range(len(old)):
        if size[k] > 0:
            transforms[k] = size[k] * np.eye(3)
            continue
        children = np.flatnonzero(example.parents == k)
        if len(children) == 1 and factor[children[0]] != 1.0:
            axis = old[children[0]] - old[k]
            length = np.linalg.norm(axis)
            if length > 1e-9:
                u = axis / length
                transforms[k] = np.eye(3) + (factor[children[0]] - 1.0) * np.outer(u, u)
    V = example.vertices
    moved = np.zeros_like(V)
    for k in np.flatnonzero(example.weights.max(axis=0) > 0):
        w = example.weights[:, k:k + 1]
        moved += w * (new[k] + (V - old[k]) @ transforms[k].T)
    # Weights that do not sum to one (a file's rounding) keep the rest of the vertex where it was.
    moved += (1.0 - example.weights.sum(axis=1, keepdims=True)) * V
    return replace(example, name=f"{example.name}~{variant}", vertices=moved, positions=new)


def _parents_first(parents: np.ndarray) -> list[int]:
    """The joints [J] in an order that lists every parent before its children (roots first)."""
    order = [int(r) for r in np.flatnonzero(parents < 0)]
    for k in order:                                   # grows as it goes: breadth first
        order.extend(int(c) for c in np.flatnonzero(parents == k))
    return order
