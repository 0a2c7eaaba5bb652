"""Conventions: where a studio puts its joints, apart from where the body is.

Two artists rigging the same body agree on its anatomy (a knee is where the leg bends) and differ by habit: 0 A.D.'s
put the thigh joints above the pelvis, Mixamo, Unity, Unreal and the glTF samples at the femoral heads. A learned
template keeps one shared anatomy (proportions, Γ, placement, confidence) and, per source of its examples, a
convention: each joint's offset from where the anatomy puts it, in a frame that moves with the body.

    frame_j    a_j along the bone the joint starts (to its child on the mid-plane, or to its only child;
               a leaf: from its parent), b_j the body's front (+z) made square to it (up, where the bone points
               forward), c_j = a_j x b_j, turned outward on the body's right side so that mirror images share
               one offset; a bone near the switch from front to up (``REFERENCE_BAND``) moves its joint by the
               two frames' moves blended, so that a bone turning through it moves the joint continuously
    scale_j    [along a, along b, along c] = [that bone's length, the limb's thickness, the limb's thickness],
               the thickness being the joint's depth inside the mesh (distance field)
    joint_j   += scale_j * (d_j[0] a_j + d_j[1] b_j + d_j[2] c_j)

so that a convention learned on slim characters moves a heavy one's hip joint by its own thigh's size, not by
its height. ``d`` [J, 3] is what a template's ``conventions`` hold, one per name (``autorig learn`` fits them,
``autorig.learn.conventions``); tips never move.
"""
from __future__ import annotations

import numpy as np

# A joint whose depth inside the mesh is smaller than this fraction of the median depth of the skeleton's joints
# (a toe near the sole, a joint just outside) is measured by that floor instead: the thickness of its limb
# rather than its own distance to the nearest surface. MIN_THICKNESS (of the height: the canonical frame is one
# unit tall) keeps a rig that lies mostly outside its mesh from dividing by nothing.
THICKNESS_FLOOR = 0.35
MIN_THICKNESS = 0.01
# A frame's second axis is the body's front made square to the bone, or its up where the bone points along the
# front: |a . front| past REFERENCE_SWITCH. The two give opposite second axes for a bone in the mid-plane's
# direction at the switch, so a hard switch moves the joint by twice its offset along b when a rounding error
# turns the bone across it (a MakeHuman body's toe 1.3 % of the height under 1e-6 noise). Within
# REFERENCE_BAND of the switch the joint's move is the two frames' moves blended, weights smooth in
# |a . front|; outside it, the one frame's as before (the learned conventions keep their meaning).
REFERENCE_SWITCH = 0.9
REFERENCE_BAND = 0.01


def bone_of(template) -> np.ndarray:
    """[J, 2] (from, to) joint indices of the bone that sets each joint's frame: to its child on the mid-plane
    (the hips to the spine, the chest to the neck), to its only child, or, for a joint without children, from
    its parent; (-1, -1) for a tip and for a root without children."""
    mirror = template.mirror_of()
    out = np.full((len(template.names), 2), -1, dtype=np.int64)
    for j, kids in enumerate(template.children):
        if template.is_tip(j):
            continue
        central = [k for k in kids if mirror[k] == k]
        if len(kids) == 1 or (kids and central):
            out[j] = (j, kids[0] if len(kids) == 1 else central[0])
        elif not kids and template.parents[j] >= 0:
            out[j] = (template.parents[j], j)
        elif kids:
            out[j] = (j, kids[0])
    return out


def front_weight(along_front) -> np.ndarray:
    """The weight of the front-referenced frame against the up-referenced one for bones whose directions'
    |a . front| is ``along_front``: 1 below the band about ``REFERENCE_SWITCH``, 0 above it, smooth (C1) in
    between."""
    t = (np.abs(np.asarray(along_front, float)) - (REFERENCE_SWITCH - REFERENCE_BAND)) / (2 * REFERENCE_BAND)
    t = np.clip(t, 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def joint_frames(joints: np.ndarray, template, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(axes [J, 3, 3], scales [J, 3]) of each joint's frame for the rig ``joints`` [J, 3] (canonical frame:
    +y up, +z front, x = 0 on the mid-plane) whose depths inside the mesh are ``depth`` [J]: axes[j] holds
    a_j, b_j, c_j as rows; scales[j] the bone's length and the thickness twice. Tips get zero scales.
    A bone within ``REFERENCE_BAND`` of the reference's switch gets the two frames' axes blended by
    ``front_weight`` (rows then neither unit nor square: the linear map from offsets to moves)."""
    joints = np.asarray(joints, float)
    J = len(joints)
    bones = bone_of(template)
    solid = np.array([not template.is_tip(j) for j in range(J)])
    floor = THICKNESS_FLOOR * float(np.median(np.maximum(depth[solid], 0.0))) if solid.any() else 0.0
    thickness = np.maximum(depth, max(floor, MIN_THICKNESS))
    axes = np.tile(np.eye(3), (J, 1, 1))
    scales = np.zeros((J, 3))
    front, up = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    mirror = template.mirror_of()
    for j, (start, end) in enumerate(bones):
        if start < 0:
            continue
        along = joints[end] - joints[start]
        length = float(np.linalg.norm(along))
        if length < 1e-9:
            continue
        a = along / length
        weight = float(front_weight(a @ front))
        frames = [(w, reference) for w, reference in ((weight, front), (1.0 - weight, up)) if w > 0]
        axes[j] = sum(w * _frame(a, reference, joints[j, 0] < -1e-6 and mirror[j] != j) for w, reference in frames)
        scales[j] = (length, thickness[j], thickness[j])
    # A limb and its mirror image share one size: a shield against one hand thickens the distance field
    # there, and should not move that wrist by more than its twin.
    for i, k in template.symmetry:
        scales[i] = scales[k] = (scales[i] + scales[k]) / 2
    return axes, scales


def _frame(a: np.ndarray, reference: np.ndarray, mirrored: bool) -> np.ndarray:
    """[3, 3] rows a, b, c of the frame of the unit bone direction ``a`` with b the ``reference`` made square
    to it; ``mirrored``: c turned outward for a joint on the body's right side."""
    b = reference - (reference @ a) * a
    b /= np.linalg.norm(b)
    c = np.cross(a, b)
    # Mirror images get mirrored axes: a left joint and its right twin share one offset.
    return np.stack([a, b, -c if mirrored else c])


def local_offsets(joints: np.ndarray, targets: np.ndarray, template, depth: np.ndarray) -> np.ndarray:
    """[J, 3] the offsets d that move ``joints`` [J, 3] onto ``targets`` [J, 3] in each joint's frame
    (``joint_frames``); 0 where a joint has no frame. A blended frame's (``REFERENCE_BAND``) is its map's
    least-squares inverse (its b rows cancel where the two frames' b are opposite)."""
    axes, scales = joint_frames(joints, template, depth)
    world = np.asarray(targets, float) - np.asarray(joints, float)
    local = np.einsum("jab,jb->ja", axes, world)
    blended = np.flatnonzero(np.abs(np.einsum("jab,jcb->jac", axes, axes) - np.eye(3)).max(axis=(1, 2)) > 1e-9)
    for j in blended:
        local[j] = np.linalg.lstsq(axes[j].T, world[j], rcond=1e-9)[0]
    return np.where(scales > 0, local / np.where(scales > 0, scales, 1.0), 0.0)


def moved(joints: np.ndarray, offsets: np.ndarray, template, depth: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` [J, 3] moved by the convention ``offsets`` [J, 3] in their own frames."""
    axes, scales = joint_frames(joints, template, depth)
    return np.asarray(joints, float) + np.einsum("jab,ja->jb", axes, np.asarray(offsets, float) * scales)


def convention_named(template, name: str | None):
    """(name, offsets [J, 3]) of ``template``'s convention ``name`` (its default for None), or (None, None)
    for a template without conventions. An unknown name is a ``TemplateError`` listing the known ones."""
    from ..errors import TemplateError
    conventions = template.conventions or {}
    if not conventions:
        if name is not None:
            raise TemplateError(f"template {template.name!r} has no conventions (it was not learned with them)")
        return None, None
    name = name or template.default_convention
    if name not in conventions:
        raise TemplateError(f"template {template.name!r} has no convention {name!r}; "
                            f"its conventions: {', '.join(sorted(conventions))}")
    return name, np.asarray(conventions[name]["offsets"], float)


def convention_shift(template, name: str | None) -> np.ndarray | None:
    """[J, 3] where the convention ``name``'s examples put the joints on average against the template's
    mean of all (template frame, one unit tall): what the learned placement pulls towards
    (``placement.learned_placement``); None for a template without conventions or a convention without it."""
    name, offsets = convention_named(template, name)
    if offsets is None:
        return None
    shift = template.conventions[name].get("shift")
    return None if shift is None else np.asarray(shift, float)


def in_convention(joints: np.ndarray, template, name: str | None, field) -> np.ndarray:
    """[J, 3] the rig ``joints`` [J, 3] (canonical frame) moved into the convention ``name`` (the template's
    default for None); unchanged for a template without conventions. A joint the move would take out of the
    mesh goes only as far as it stays inside (or, already out, no further out)."""
    _, offsets = convention_named(template, name)
    if offsets is None:
        return joints
    depth = field.depth(joints)
    placed = moved(joints, offsets, template, depth)
    solid = np.array([not template.is_tip(j) for j in range(len(template.names))])
    # A joint goes as far along its move as it stays inside (or, outside already, no further out): left
    # where it was whenever the whole move ended outside, a toe in a thin foot stayed or moved by the whole
    # offset as a rounding error of the mesh decided (1.3 % of a MakeHuman body's height).
    share = np.ones(len(joints))
    share[solid] = _share_inside(field, joints[solid], placed[solid], depth[solid])
    # Mirror images move alike: one wrist moved less than its twin would make a symmetric body's rig lopsided.
    share = np.minimum(share, share[template.mirror_of()])
    return joints + share[:, None] * (placed - joints)


def _share_inside(field, start: np.ndarray, end: np.ndarray, depth: np.ndarray, steps: int = 16) -> np.ndarray:
    """[N] how much of each move ``start`` -> ``end`` [N, 3] stays inside the mesh, or for a point already out
    (``depth`` [N] < 0) no further out than it was: 1 when the end does, else where the way crosses that level
    (bisection)."""
    level = np.minimum(depth, 0.0)
    share = np.ones(len(start))
    out = np.flatnonzero(field.depth(end) < level)
    if len(out):
        a, b = start[out], end[out]
        lo, hi = np.zeros(len(out)), np.ones(len(out))
        for _ in range(steps):
            mid = (lo + hi) / 2
            inside = field.depth(a + mid[:, None] * (b - a)) >= level[out]
            lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
        share[out] = lo
    return share


def parse_conventions(data, names: list[str], order: list[str], default, bad) -> tuple[dict | None, str | None]:
    """(conventions, default name) of a template file's ``"conventions"`` object ({name: {"offsets": [J rows
    of 3 numbers, in the file's joint order], ...}}) and ``"default_convention"``, checked; offsets come back
    in the template's parents-first ``order``. ``bad`` makes the error."""
    if data is None:
        if default is not None:
            raise bad('"default_convention" without "conventions"')
        return None, None
    if not isinstance(data, dict) or not data:
        raise bad('"conventions" must be an object {name: {"offsets": [...]}}')
    index = {n: i for i, n in enumerate(names)}

    def rows(value) -> bool:
        return isinstance(value, list) and len(value) == len(names) and all(
            isinstance(row, list) and len(row) == 3 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) < 10 for v in row)
            for row in value)

    out = {}
    for name, convention in data.items():
        if not isinstance(convention, dict) or not rows(convention.get("offsets")) or (
                convention.get("shift") is not None and not rows(convention["shift"])):
            raise bad(f'convention {name!r}: "offsets" (and "shift", if given) must be {len(names)} rows of three '
                      f'numbers, one per joint')
        out[str(name)] = {**convention, **{key: [[float(v) for v in convention[key][index[n]]] for n in order]
                                           for key in ("offsets", "shift") if convention.get(key) is not None}}
    if default is None:
        default = next(iter(out))
    if default not in out:
        raise bad(f'"default_convention" {default!r} is not one of the conventions ({", ".join(out)})')
    return out, str(default)


def conventions_dict(template) -> dict:
    """The template's conventions as its JSON file holds them (offsets rounded, in the template's order)."""
    return {name: {**{k: v for k, v in c.items() if k not in ("offsets", "shift")},
                   **{key: [[round(float(v), 4) for v in row] for row in c[key]]
                      for key in ("shift", "offsets") if c.get(key) is not None}}
            for name, c in (template.conventions or {}).items()}
