"""Pinocchio's output files (Baran & Popović 2007, the ``demo`` program's ``skeleton.out`` and
``attachment.out``), written into one folder.

``skeleton.out``   one line per joint ``i``: ``i x y z parent``, with parent ``-1`` for the root (joint 0).
``attachment.out`` one line per vertex, in input order, one column per *bone*: Pinocchio's bone ``b`` is the
                   bone from joint ``parent[b + 1]`` to joint ``b + 1``, so a rig of ``J`` joints has ``J - 1``
                   columns. Weights have 6 decimals (Pinocchio itself writes 4); each line sums to 1 within
                   about 1e-5.
``joint_names.txt`` one line per joint: ``i name`` (Pinocchio has no names; this keeps them).

Converting the weights. In a :class:`Rig` a vertex follows *joints*, and a joint's transform moves the bones
that leave it (glTF's convention). In Pinocchio a vertex follows *bones*, and a bone turns about its parent
joint, so the bone ``p -> c`` moves as joint ``p`` does. Hence the column of bone ``p -> c`` gets:

- joint ``p``'s weight, shared equally among ``p``'s children when ``p`` has several (e.g. hips -> spine,
  hips -> left hip, hips -> right hip each get a third of the hips' weight);
- plus joint ``c``'s own weight if ``c`` is a tip: a tip owns no bone, and the bone ending at it is the one
  that carries it. A rig normally gives tips no weight at all, so this only keeps rows summing to 1.
"""
from __future__ import annotations

import os

import numpy as np

from ..result import Rig
from .arrays import check_rig, decimal_strings
from .files import write_folder_atomic

__all__ = ["write_pinocchio", "pinocchio_files", "bone_weights", "FILES"]

FILES = ("skeleton.out", "attachment.out", "joint_names.txt")


def write_pinocchio(rig: Rig, folder: str | os.PathLike) -> None:
    """Write ``rig`` as a Pinocchio folder (see the module docstring), atomically.

    An existing folder holding only these files is replaced; anything else there raises ``OutputError``.
    """
    write_folder_atomic(folder, pinocchio_files(rig))


def pinocchio_files(rig: Rig) -> dict[str, bytes]:
    """{file name: content} of the Pinocchio folder for ``rig``; the same rig always gives the same bytes."""
    check_rig(rig)
    parents = np.asarray(rig.parents, dtype=np.int64)
    joints = np.asarray(rig.joints, dtype=np.float64)
    skeleton = "".join(f"{i} {_number(x)} {_number(y)} {_number(z)} {p}\n"
                       for i, ((x, y, z), p) in enumerate(zip(joints, parents)))
    names = "".join(f"{i} {name}\n" for i, name in enumerate(rig.names))

    cells = decimal_strings(bone_weights(rig.weights, parents), 6)
    attachment = "".join(" ".join(row) + "\n" for row in cells)
    return dict(zip(FILES, (skeleton.encode(), attachment.encode(), names.encode("utf-8"))))


def unfit_skeleton(parents) -> str | None:
    """Why Pinocchio's files cannot hold a skeleton (parents [J], -1 for a root), or None: they need one root
    joint and at least one bone."""
    parents = np.asarray(parents)
    roots = int(np.count_nonzero(parents < 0))
    if len(parents) >= 2 and roots == 1:
        return None
    return (f"the pinocchio format needs a skeleton with one root joint and at least one bone; this one has "
            f"{roots} roots and {len(parents)} joints")


def bone_weights(weights: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """Per-joint skin weights turned into Pinocchio's per-bone weights (see the module docstring).

    weights  [V, J] column j = how much each vertex follows joint j
    parents  [J] parent index of each joint, -1 for the root, which must be joint 0 and the only root
    returns  [V, J - 1] column b = how much each vertex follows the bone from ``parents[b + 1]`` to ``b + 1``
    """
    weights = np.asarray(weights, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    problem = unfit_skeleton(parents)
    if problem:
        raise ValueError(problem)
    children = np.bincount(parents[1:], minlength=len(parents))
    bones = weights[:, parents[1:]] / children[parents[1:]]
    tips = children[1:] == 0
    bones[:, tips] += weights[:, 1:][:, tips]
    return bones


def _number(x: float) -> str:
    text = f"{x:.9g}"
    # "-0" would read back fine but makes otherwise equal files differ.
    return "0" if text == "-0" else text
