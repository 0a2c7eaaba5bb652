"""What every format needs of a rig's arrays: checked shapes, parents before children, weights as text."""
from __future__ import annotations

import numpy as np

from ..result import Rig


def check_rig(rig: Rig) -> None:
    """Raise ``ValueError`` if ``rig``'s arrays disagree in shape or hold values no format can store.

    A malformed rig is a bug upstream, not something the user can fix, hence not an ``AutorigError``.
    """
    J = len(rig.names)
    parents = np.asarray(rig.parents)
    joints = np.asarray(rig.joints)
    weights = np.asarray(rig.weights)
    vertices = np.asarray(rig.vertices)
    faces = np.asarray(rig.faces)
    if J == 0:
        raise ValueError("rig has no joints")
    if parents.shape != (J,) or joints.shape != (J, 3):
        raise ValueError(f"rig has {J} names but parents {parents.shape} and joints {joints.shape}")
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise ValueError(f"rig vertices have shape {vertices.shape}, expected [V, 3] with V > 0")
    if weights.shape != (len(vertices), J):
        raise ValueError(f"rig weights have shape {weights.shape}, expected {(len(vertices), J)}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise ValueError(f"rig faces have shape {faces.shape}, expected [F, 3] with F > 0")
    if not all(-1 <= int(p) < j for j, p in enumerate(parents)):
        raise ValueError("rig parents must be -1 or the index of an earlier joint")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError("rig faces index vertices that do not exist")
    for name, array in (("joints", joints), ("vertices", vertices), ("weights", weights)):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"rig {name} contain NaN or infinity")
    if weights.size and weights.min() < 0:
        raise ValueError("rig weights must be >= 0")


def parents_first(parents: np.ndarray) -> tuple[list[int], np.ndarray]:
    """The joints (parents [J], -1 for a root) reordered so that every parent precedes its children, as close to
    0..J-1 as can be: (order [J], the old index of each joint in the new order; parents [J] in the new order
    and numbering)."""
    order: list[int] = []
    placed = np.zeros(len(parents), dtype=bool)
    for j in range(len(parents)):
        chain = []
        while j >= 0 and not placed[j]:
            chain.append(j)
            placed[j] = True
            j = parents[j]
        order.extend(reversed(chain))
    new_index = np.empty(len(parents), dtype=np.int64)
    new_index[order] = np.arange(len(parents))
    return order, np.array([new_index[parents[j]] if parents[j] >= 0 else -1 for j in order], dtype=np.int64)


def decimal_strings(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` rounded to ``decimals`` decimal places, as text: an object array of the same shape.

    Plain fixed-point, shortest form: ``0.25``, ``1``, ``0.000001``, ``0`` (never ``-0`` or an exponent),
    so a value always prints the same way and the text reads back as the rounded value. Weight tables are
    millions of cells over a few hundred thousand distinct values, so each distinct value is formatted once.
    """
    scaled = np.round(np.asarray(values, dtype=np.float64) * 10 ** decimals).astype(np.int64)
    if scaled.size == 0:
        return np.empty(scaled.shape, dtype=object)
    low, high = int(scaled.min()), int(scaled.max())
    if high - low <= 4 * scaled.size:
        # Weights span a small range of integers: a lookup table finds the distinct ones without sorting.
        present = np.zeros(high - low + 1, dtype=bool)
        present[scaled - low] = True
        distinct = np.flatnonzero(present) + low
        table = np.empty(len(present), dtype=object)
        table[distinct - low] = [_fixed_point(q, decimals) for q in distinct.tolist()]
        return table[scaled - low]
    texts = np.empty(scaled.size, dtype=object)
    texts[:] = [_fixed_point(q, decimals) for q in scaled.ravel().tolist()]
    return texts.reshape(scaled.shape)


def _fixed_point(q: int, decimals: int) -> str:
    """``q / 10**decimals`` written out exactly, without trailing zeros."""
    whole, fraction = divmod(abs(q), 10 ** decimals)
    digits = f"{fraction:0{decimals}d}".rstrip("0")
    return ("-" if q < 0 else "") + str(whole) + ("." + digits if digits else "")
