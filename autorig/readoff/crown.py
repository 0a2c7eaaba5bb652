"""An upright head's bone: its tip up to the crown, and where its skin begins (the base of the skull).

Retargeting and every engine read a bone's direction from its two ends, so ``head_end`` sets which way the head
points: where the embedding's path left it (at the front of a big face, 60 degrees off vertical on Homer) a
walk clip, whose head bone points up, tips the head back by as much. Here ``head_end`` goes straight up from
the head joint to the top of the head: the highest surface point within ``CROWN_REACH`` head radii of the
vertical through the joint (the head's radius: the depth of the deepest point on that vertical within the
head). A maximum over a region that grows and shrinks with the mesh is continuous in it: a mesh moved by a
hair moves the tip by a hair.

Bone heat gives each vertex to its nearest visible bone, and a head joint placed at eye level (the convention
of the examples the biped learned from) leaves the face and jaw nearer the neck's bone than the head's. The
head's weights should begin where the head meets the neck: ``skull_base`` reads, on the body's mid-plane,
the height between the neck's lower half and the head joint where the body is thinnest from front to back
(below a jaw, that is below the chin; the top of a neck of even thickness; not a slit such as parted lips,
narrower than ``SLIT`` of the height, closed over first: the ogre's open mouth had left its jaw on the
chest); the heat is then solved with the head's bone starting there, while the joint itself, the head's
pivot, stays where it is.

Only for templates whose head bone points up (the biped and humanoid); a four-legged head is left alone.
"""
from __future__ import annotations

import numpy as np

CROWN_REACH = 1.5        # head radii around the vertical through the head joint that the crown is sought in
UPRIGHT = 0.8            # a template's head bone points up if its direction's up component is above this
PROFILE_HEIGHTS = 49     # heights sampled between the neck's lower half and the head joint
PROFILE_DEPTHS = 121     # points across the body's depth at each height
THIN = 1.05              # heights no deeper than this x the thinnest (and two samples) are the neck's thin part
SLIT = 0.01              # a thinner band than this fraction of the height is a slit (an open mouth), not a neck


def upright_head(template) -> tuple[int, int, int, int] | None:
    """(chest, neck, head, head_end) joint indices of a template whose head bone points up, else None."""
    names = list(template.names)
    if not all(n in names for n in ("neck", "head", "head_end")):
        return None
    neck, head, tip = names.index("neck"), names.index("head"), names.index("head_end")
    d = template.positions[tip] - template.positions[head]
    if np.linalg.norm(d) == 0 or d[1] / np.linalg.norm(d) < UPRIGHT or template.parents[tip] != head:
        return None
    return int(template.parents[neck]), neck, head, tip


def crown_tip(joints: np.ndarray, template, vertices: np.ndarray, depth) -> np.ndarray:
    """[J, 3] ``joints`` (canonical frame, +y up) with ``head_end`` straight above the head joint at the top of
    the head (see the module docstring); unchanged for a template without an upright head. ``vertices``
    [V, 3] the mesh in the same frame; ``depth`` the distance field's ``depth`` (inside > 0)."""
    found = upright_head(template)
    if found is None:
        return joints
    _, _, head, tip = found
    h = joints[head]
    top = float(vertices[:, 1].max())
    column = np.column_stack([np.full(64, h[0]), np.linspace(h[1], top, 64), np.full(64, h[2])])
    radius = float(np.max(depth(column)))
    if not radius > 0:
        return joints
    near = np.hypot(vertices[:, 0] - h[0], vertices[:, 2] - h[2]) <= CROWN_REACH * radius
    crown = float(vertices[near, 1].max()) if near.any() else top
    if crown <= h[1]:
        return joints
    out = joints.copy()
    out[tip] = [h[0], crown, h[2]]
    return out


def skull_base(joints: np.ndarray, template, depth, vertices: np.ndarray) -> float | None:
    """The height (canonical y) where the head's weights begin: on the mid-plane (x of the neck joint), the
    height between halfway from the neck's parent to the neck and the head joint where the inside of the body
    is shallowest from front to back (within a quarter of the height of the neck): the top of the lowest run
    of heights as shallow as that (within ``THIN`` and two samples); None for a template
    without an upright head or where the body is not found there."""
    found = upright_head(template)
    if found is None:
        return None
    chest, neck, head, _ = found
    low = joints[neck][1] - 0.5 * (joints[neck][1] - joints[chest][1])
    if not joints[head][1] > low:
        return None
    height = float(np.ptp(vertices[:, 1]))
    y = np.linspace(low, joints[head][1], PROFILE_HEIGHTS)
    z = joints[neck][2] + np.linspace(-0.25, 0.25, PROFILE_DEPTHS) * height
    Y, Z = np.meshgrid(y, z, indexing="ij")
    inside = depth(np.column_stack([np.full(Y.size, joints[neck][0]), Y.ravel(), Z.ravel()])).reshape(Y.shape) > 0
    if not inside.any(axis=1).all():
        return None
    first = np.argmax(inside, axis=1)
    last = PROFILE_DEPTHS - 1 - np.argmax(inside[:, ::-1], axis=1)
    # a slit (lips parted on the mid-plane, one height thin) is no neck: dips narrower than SLIT closed over
    step = (joints[head][1] - low) / (PROFILE_HEIGHTS - 1)
    width = 2 * int(np.ceil(0.5 * SLIT * height / step)) + 1
    extent = _closing(z[last] - z[first], width)
    # a neck of even thickness is thinnest all along: the head begins at the top of the lowest thin run (an
    # open mouth above it can be as thin: which of the two is the higher would be a near-tie)
    thin = extent <= THIN * extent.min() + 2 * (z[1] - z[0])
    start = int(np.argmax(thin))
    stop = start + (int(np.argmin(thin[start:])) if not thin[start:].all() else len(thin) - start)
    return float(y[stop - 1])


def _closing(values: np.ndarray, width: int) -> np.ndarray:
    """[N] the grey closing of ``values`` [N] over ``width`` (odd) samples, edges repeated: the running maximum,
    then the running minimum; dips narrower than ``width`` filled, wider ones kept as they are (numpy's
    sliding windows: scipy.ndimage costs every rig 75 ms to import)."""
    from numpy.lib.stride_tricks import sliding_window_view

    half = width // 2
    high = sliding_window_view(np.pad(values, half, mode="edge"), width).max(axis=1)
    return sliding_window_view(np.pad(high, half, mode="edge"), width).min(axis=1)


def heat_joints(joints: np.ndarray, template, base: float | None) -> np.ndarray:
    """[J, 3] the joints the heat is solved with: the head's bone starting at the skull's ``base`` height (on
    the neck's bone, or on the bone below it with the neck's bone halved, when the base lies below the neck
    joint); ``joints`` itself when the base is None or not below the head joint."""
    found = upright_head(template)
    if found is None or base is None:
        return joints
    chest, neck, head, _ = found
    if not base < joints[head][1]:
        return joints
    out = joints.copy()
    lower, upper = (neck, head) if base >= joints[neck][1] else (chest, neck)
    a, b = joints[lower], joints[upper]
    t = np.clip((base - a[1]) / (b[1] - a[1]), 0.0, 1.0) if b[1] != a[1] else 1.0
    out[head] = a + t * (b - a)
    if upper == neck:
        out[neck] = 0.5 * (joints[chest] + out[head])
    return out
