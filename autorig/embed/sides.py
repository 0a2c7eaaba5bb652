"""A rig's side limbs (arms, legs) against its mid-plane: their chains of joints, how long they are against the
template's, mirror pairs that crossed over the mid-plane, and limb ends against the neck and head. What the
confidence's ``sides``, ``reach`` and ``head`` parts read (``autorig.confidence``), and what the embedding's
second try with two limb ends swapped looks for (``autorig.pipeline.embed_and_refine``)."""
from __future__ import annotations

import numpy as np

from ..template import Template

# ``sides``: the mirror pairs this many bones or fewer from the mid-plane's joints (1: shoulders, hips; 2: elbows,
# knees), and how far (heights) past each other across the mid-plane two of them must be to count as crossed.
SIDE_DEPTH = 2
SIDE_MARGIN = 0.02
# The largest fraction of the straight line from the wrist to the chain that may lie outside the mesh for the two
# to count as joined through it (a wrist on the surface of a low-poly arm has a sample or two just outside).
HEAD_JOINED = 0.05
HEAD_SAMPLES = 64


def side_chains(template: Template) -> list[list[int]]:
    """The template's side limbs as chains of joints from the first off the mid-plane (a shoulder, a hip) down
    its single line of joints with bones (to a wrist, a toe), without the legs read off the mesh
    (``readoff.legs``, whose lengths are the animal's own)."""
    mirror = template.mirror_of()
    kids = [[] for _ in template.names]
    for j, p in enumerate(template.parents):
        if p >= 0 and not template.is_tip(j):
            kids[int(p)].append(j)
    read = set()
    if template.legs:
        from ..readoff.legs import legs_of
        read = {j for chain in legs_of(template) for j in chain}
    chains = []
    for j, p in enumerate(template.parents):
        if mirror[j] == j or (p >= 0 and mirror[int(p)] != int(p)) or template.is_tip(j) or j in read:
            continue
        chain = [j]
        while len(kids[chain[-1]]) == 1:
            chain.append(kids[chain[-1]][0])
        if len(chain) > 1:
            chains.append(chain)
    return chains


def chain_ratios(joints: np.ndarray, template: Template) -> list[tuple[list[int], float]]:
    """(chain, its length in ``joints`` [J, 3] over the template's) of each of ``side_chains``."""
    out = []
    for chain in side_chains(template):
        rig = np.linalg.norm(np.diff(joints[chain], axis=0), axis=1).sum()
        ref = np.linalg.norm(np.diff(template.positions[chain], axis=0), axis=1).sum()
        if ref > 1e-9:
            out.append((chain, float(rig / ref)))
    return out


def crossed_pairs(joints: np.ndarray, template: Template) -> list[tuple[int, int]]:
    """The template's mirror pairs within ``SIDE_DEPTH`` bones of the mid-plane's joints lie each on
    the other's side of the body in ``joints`` [J, 3] (canonical frame: x = 0 the mid-plane) by more than
    ``SIDE_MARGIN``: an arm's chain that crossed to the other arm (a rig of a character with its arms folded
    in front of it, its elbows swapped). Hands and feet are not counted: they may cross in a right rig."""
    mirror = template.mirror_of()
    crossed = []
    for i, j in template.symmetry:
        depth, k = 0, int(i)
        while k >= 0 and mirror[k] != k:
            k, depth = int(template.parents[k]), depth + 1
        if k < 0 or depth > SIDE_DEPTH:
            continue
        side = np.sign(template.positions[i, 0] - template.positions[j, 0])
        if side * (joints[i, 0] - joints[j, 0]) < -SIDE_MARGIN:
            crossed.append((int(i), int(j)))
    return crossed


def head_chains(template: Template) -> dict[int, list[int]]:
    """{side limb's end joint: the mid-plane chain beside its limb}: for each of ``side_chains`` (an arm), the
    joints, in order, of each mid-plane chain that starts at a child of the limb's parent joint and runs without
    branching to a tip (the neck, the head and its tip beside the arms, off the chest); the longest if more. A
    leg has none beside it (the spine branches), nor has a four-legged template (its legs are read off)."""
    mirror = template.mirror_of()
    kids = [[] for _ in template.names]
    for j, p in enumerate(template.parents):
        if p >= 0:
            kids[int(p)].append(j)
    out = {}
    for chain in side_chains(template):
        parent = int(template.parents[chain[0]])
        best: list[int] = []
        for start in (kids[parent] if parent >= 0 else []):
            if mirror[start] != start:
                continue
            line = [start]
            while len(kids[line[-1]]) == 1 and mirror[kids[line[-1]][0]] == kids[line[-1]][0]:
                line.append(kids[line[-1]][0])
            if template.is_tip(line[-1]) and not kids[line[-1]] and len(line) > len(best):
                best = line
        if len(best) > 1:
            out[chain[-1]] = best
    return out


def at_head(field, joints: np.ndarray, template: Template) -> list[tuple[int, float]]:
    """(side limb's end joint, ``near``) for each of ``head_chains``' ends (a wrist) joined to its chain through
    the mesh: its distance to the chain's polyline (``joints`` [J, 3], canonical frame) over the chain's length,
    counted when no more than ``HEAD_JOINED`` of the straight line from it to the polyline's nearest point lies
    outside the mesh (``field``: depth below 0)."""
    out = []
    for end, line in head_chains(template).items():
        points = joints[line]
        length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        if length <= 1e-9:
            continue
        p = joints[end]
        a, b = points[:-1], points[1:]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0, 1)
        nearest = a + t[:, None] * ab
        gaps = np.linalg.norm(nearest - p, axis=1)
        q = nearest[int(np.argmin(gaps))]
        line_points = p + np.linspace(0.0, 1.0, HEAD_SAMPLES)[:, None] * (q - p)
        if np.mean(field.depth(line_points) < 0) <= HEAD_JOINED:
            out.append((int(end), float(gaps.min()) / length))
    return out


def in_limbs(field, joints: np.ndarray, template: Template) -> list[tuple[int, float]]:
    """(side limb's end joint, ``ratio``) for each of ``side_chains``' ends (a wrist, a toe) near a bone of another
    side chain (an arm's end against the legs' bones, a foot's against the arms'): the end's distance to that
    bone's nearest point over the mesh's depth there (``field``), the least over the bones whose nearest point
    lies inside the mesh. Below 1 the end lies within the other limb's flesh: hands on the hips hid the arms'
    ends and their chains ran down into the thighs. ``joints`` [J, 3], canonical frame."""
    chains = side_chains(template)
    out = []
    for chain in chains:
        p = joints[chain[-1]]
        bones = [(a, b) for other in chains if other is not chain for a, b in zip(other[:-1], other[1:])]
        if not bones:
            continue
        a = joints[[i for i, _ in bones]]
        ab = joints[[j for _, j in bones]] - a
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0, 1)
        nearest = a + t[:, None] * ab
        depth = field.depth(nearest)
        ratios = np.linalg.norm(nearest - p, axis=1)[depth > 0] / depth[depth > 0]
        if len(ratios):
            out.append((int(chain[-1]), float(ratios.min())))
    return out
