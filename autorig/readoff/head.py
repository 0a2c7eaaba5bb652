"""The head joint read off the mesh: a share of the way from the front paws to the snout, not the template's.

The embedding's head chain often stops short of the snout (a boar's, a pig's, a rhino's: 10-52 % of the height)
or climbs a horn, and the placement pulls a raised head toward the template's; the head joint follows it. The
snout itself is easy to find on the mesh, and the front paws are where the embedding finds them (about 4 % of the
height off), so the head is measured between the two instead. In the canonical frame (+y up, one unit tall,
facing +z), on the body's mid-plane (the x half-way between the front legs' feet), over a grid of ``STEP``:

    paws     the front feet's mean z
    tip      going forward from the paws, the last z whose mid-plane column is still inside the mesh (the
             snout's end; a horn or a tusk off the mid-plane does not count)
    column   at z = tip - k * (tip - paws): its deepest point's height and its depth (half-thickness)

and the joint goes to (x, deepest + m * depth, tip - k * (tip - paws)), k and m the medians over the examples
(``learn_head``), unless the embedding's head chain ended within ``REACHED`` of the snout (blended between its
two bounds): there its head was as near its artist's as the rule's or nearer (cow, giraffe, goat, wildebeest: 7-9 % against 12-17 %). The share k is the animal's own length of head and neck in one number: an absolute distance
behind the snout (a head of one size for every animal) or one in trunk depths rigged the corpus's held-out
species worse (14.9 and 9.8 % mean against 7.7 % with the artists' paws, see docs/tutorials/learn.md). The
neck, when it no longer sits between the chest and the new head along the back, goes half-way between them.
The template's ``legs`` carries the rule as ``{"head": {"snout": [k, m]}}``; a template without it, or a mesh
whose snout or head column cannot be measured, keeps its joints.
"""
from __future__ import annotations

import numpy as np

STEP = 0.01
JOINT = "head"
NECK, CHEST = "neck", "chest"
MIN_EXAMPLES = 4
# How near the snout's end (in heights) the embedding's head chain must end for its head to be kept. On the
# corpus the chains either reach the snout (0.3-2.3 % short along the back) or stop well short of it, in a
# tusk or the neck (7.4-52 %), or climb a horn (the aurochs's, 9.9 % short and 23 % above the snout). Between
# the two bounds the head is blended from the embedding's to the rule's, so that a chain's end moving across
# one bound (a wolf's, 3.6 % under a re-export's rounding) moves the head as little as the end moved.
REACHED = (0.03, 0.07)


def measure_head(depth, vertices: np.ndarray, joints: np.ndarray, template) -> tuple | None:
    """(x, paws, snout [3] (x, the tip column's deepest point, tip), column) from a signed ``depth`` (points [N, 3] -> [N], > 0 inside), the ``vertices``
    [V, 3] and the front feet in ``joints`` [J, 3] (canonical frame), where ``column(z)`` gives (deepest point's
    height, depth) of the mid-plane's column at z, or None when it is not inside; None without front legs or a
    snout ahead of them."""
    from .legs import legs_of
    from .rump import midplane_depths
    feet = np.array([joints[chain[-1]] for chain in legs_of(template)]).reshape(-1, 3)
    roots = np.array([joints[chain[0]] for chain in legs_of(template)]).reshape(-1, 3)
    if len(feet) < 4:
        return None
    front = feet[roots[:, 2] >= np.median(roots[:, 2])]
    x, paws = float(front[:, 0].mean()), float(front[:, 2].mean())
    Y = np.arange(float(vertices[:, 1].min()), float(vertices[:, 1].max()), STEP)
    Z = np.arange(paws, float(vertices[:, 2].max()) + STEP, STEP)
    if len(Y) < 2 or len(Z) < 2:
        return None

    def grid(z: np.ndarray) -> np.ndarray:      # [len(z), len(Y)] depths of the mid-plane's columns at z
        return midplane_depths(depth, x, z, Y)

    inside = np.nonzero(grid(Z).max(axis=1) > 0)[0]
    if not len(inside) or Z[inside[-1]] - paws < 2 * STEP:
        return None
    tip = float(Z[inside[-1]])

    def column(z: float):
        d = grid(np.array([z]))[0]
        return None if d.max() <= 0 else (float(Y[int(np.argmax(d))]), float(d.max()))
    return x, paws, np.array([x, column(tip)[0], tip]), column


def read_head(joints: np.ndarray, template, depth, vertices: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` with the head moved by the template's learned rule (``measure_head``) and the neck
    kept between the chest and the head; unchanged without the rule or the measurement."""
    from .rump import ruled_measurement
    found = ruled_measurement(joints, template, JOINT, "snout", measure_head, depth, vertices)
    if found is None:
        return joints
    rule, (x, paws, snout, column) = found
    tip = float(snout[2])
    head = template.names.index(JOINT)
    ends = [c for c in template.children[head] if not template.children[c]]
    reach = min(float(np.linalg.norm(joints[c] - snout)) for c in ends) if ends else np.inf
    keep = float(np.clip((REACHED[1] - reach) / (REACHED[1] - REACHED[0]), 0.0, 1.0))
    if keep >= 1.0:
        return joints    # the embedding's head chain reached the snout: its head is the mesh's own
    z = tip - rule[0] * (tip - paws)
    section = column(z)
    if section is None:
        return joints
    out = joints.copy()
    out[head] = keep * joints[head] + (1.0 - keep) * np.array([x, section[0] + rule[1] * section[1], z])
    if NECK in template.names and CHEST in template.names:
        neck, chest = template.names.index(NECK), template.names.index(CHEST)
        # A head moved back past the neck would fold the neck chain over itself; half-way keeps it a chain.
        if not min(out[chest, 2], out[head, 2]) <= out[neck, 2] <= max(out[chest, 2], out[head, 2]):
            out[neck] = (out[chest] + out[head]) / 2
    return out


def learn_head(examples, per_example: np.ndarray, template) -> tuple[list[float] | None, int]:
    """([k, m] or None, how many examples measured): the medians over ``examples`` (``learn.examples.Example``,
    their joints in the template frame ``per_example`` [N, J, 3]) that map the head, of how far back from the
    snout toward the front paws (k, a share) and above the deepest point of that column (m, in its depths)
    their artists put it. Medians, so that one species' odd head (a giraffe's on its long neck) does not move
    every animal's."""
    from .rump import measured_examples
    if JOINT not in template.names:
        return None, 0
    j = template.names.index(JOINT)
    rows = []
    for truth, (_, paws, (_, _, tip), column) in measured_examples(examples, per_example, template, JOINT, measure_head):
        section = column(float(truth[j, 2]))
        if section is not None:
            rows.append(((tip - truth[j, 2]) / (tip - paws), (truth[j, 1] - section[0]) / section[1]))
    if len(rows) < MIN_EXAMPLES:
        return None, len(rows)
    return [round(float(v), 4) for v in np.median(np.array(rows), axis=0)], len(rows)
