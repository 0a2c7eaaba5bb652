"""Skeleton files for ``autorig MESH --skeleton FILE``: :func:`read_skeleton` reads one into a :class:`Skeleton`.

- ``.json``: ``{"joints": [{"name": ..., "parent": ..., "position": [x, y, z]}, ...]}`` with ``parent`` a joint
  name, ``null`` for a root, or an index into the list (-1 for a root), so autorig's own ``--format json``
  output reads as a skeleton too. Other keys are ignored.
- ``.glb`` / ``.gltf``: the joints of the skin of the first skinned mesh (else the first skin): names,
  hierarchy (a joint's parent is its nearest ancestor node that is a joint of the skin) and bind pose (joint
  positions from the inverse bind matrices, else from the nodes' world transforms). The joints' nodes, the
  non-joint nodes above them and the inverse bind matrices are kept (``JointNodes``), so that the re-weighted
  rig is written back with the same hierarchy, node transforms and bind pose.
- ``.bvh``: the rest pose of the hierarchy (every channel zero), in the file's units; each ``End Site`` gives
  its joint's bone end (``Skeleton.tips``). The motion, if any, is not read.

Positions are taken as they are; fitting a skeleton to a mesh of other units is ``autorig.weights.bones.fit_to_mesh``.
Anything that is not a joint tree (no joints, a bad or cyclic parent, a duplicate name, a position that is not
three finite numbers, a glTF without a skin, a BVH syntax error) raises ``SkeletonError`` with one line.
"""
from __future__ import annotations

import json
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, SkeletonError
from ..input.limits import MAX_JOINTS, read_regular
from ..result import JointNodes
from .arrays import parents_first

__all__ = ["Skeleton", "read_skeleton", "skeleton_from_joints", "SKELETON_FORMATS"]

SKELETON_FORMATS = (".json", ".glb", ".gltf", ".bvh")


@dataclass
class Skeleton:
    """A user's skeleton, joints ordered parents first.

    names        [J] joint names
    parents      [J] int, index of each joint's parent (earlier in the list), -1 for a root; several roots allowed
    positions    [J, 3] float64 joint positions (the file's coordinates and units)
    tips         [J, 3] float64 where the file says a joint's own bone ends (a BVH ``End Site``), NaN elsewhere
    kind         "json", "gltf" or "bvh": what the file was
    joint_nodes  the glTF's joint hierarchy to write back (``JointNodes``), None for other files
    """
    names: list[str]
    parents: np.ndarray
    positions: np.ndarray
    tips: np.ndarray
    kind: str
    joint_nodes: JointNodes | None = None


def read_skeleton(path: str | os.PathLike) -> Skeleton:
    """Read a ``.json``, ``.glb``/``.gltf`` or ``.bvh`` skeleton file (see the module docstring)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SKELETON_FORMATS:
        raise SkeletonError(f"skeleton {path}: unknown skeleton format {suffix or '(no extension)'!r}; "
                            f"autorig reads {', '.join(SKELETON_FORMATS)}")
    try:
        data = read_regular(path, None)
    except OSError as e:
        raise SkeletonError(f"skeleton {path}: cannot read ({e.strerror or e})") from None
    if suffix == ".json":
        skeleton = _from_json(data, path)
    elif suffix == ".bvh":
        skeleton = _from_bvh(data, path)
    else:
        skeleton = _from_gltf(data, path)
    if len(skeleton.names) > MAX_JOINTS:  # each joint's bone heat is one solve over the surface
        raise SkeletonError(f"skeleton {path}: {len(skeleton.names):,} joints, more than the {MAX_JOINTS:,} "
                            f"autorig weighs")
    return skeleton


def skeleton_from_joints(names, parents, positions, *, source: str = "skeleton", tips=None, kind: str = "json",
                         joint_nodes: JointNodes | None = None) -> Skeleton:
    """A checked ``Skeleton`` from joints in any order.

    names [J]; parents [J] int (index of the parent in this list, -1 for a root); positions [J, 3]; tips [J, 3]
    or None. Joints are reordered parents first (otherwise keeping their order). ``source`` names the file in
    errors. ``joint_nodes``, if given, must already list the joints in an order with parents first.
    """
    def bad(message):
        return SkeletonError(f"skeleton {source}: {message}")

    names = [str(n) for n in names]
    J = len(names)
    if J == 0:
        raise bad("no joints")
    if len(set(names)) != J:
        raise bad(f"duplicate joint names {sorted({n for n in names if names.count(n) > 1})[:5]}")
    parents = np.asarray(parents, dtype=np.int64).reshape(-1)
    positions = np.asarray(positions, dtype=np.float64).reshape(J, 3)
    tips = np.full((J, 3), np.nan) if tips is None else np.asarray(tips, dtype=np.float64).reshape(J, 3)
    bad_position = ~np.isfinite(positions).all(axis=1)
    if bad_position.any():
        raise bad(f"joint {names[int(np.argmax(bad_position))]!r} has a position that is not finite")
    for j, p in enumerate(parents):
        if p < -1 or p >= J or p == j:
            raise bad(f"joint {names[j]!r} has a bad parent")
    # A walk up from any joint must reach a root within J steps, else there is a cycle.
    for j in range(J):
        up, steps = j, 0
        while up >= 0:
            up, steps = parents[up], steps + 1
            if steps > J:
                raise bad(f"joint {names[j]!r} is its own ancestor (a parent cycle)")
    order, ordered_parents = parents_first(parents)
    return Skeleton(names=[names[j] for j in order], parents=ordered_parents, positions=positions[order],
                    tips=tips[order], kind=kind, joint_nodes=joint_nodes)


# ------------------------------------------------------------------------------------------------------- JSON

def _from_json(data: bytes, path: Path) -> Skeleton:
    try:
        document = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as e:
        raise SkeletonError(f"skeleton {path}: not valid JSON ({e})") from None
    except RecursionError:
        raise SkeletonError(f"skeleton {path}: the JSON nests too deeply") from None
    joints = document.get("joints") if isinstance(document, dict) else None
    if not isinstance(joints, list):
        raise SkeletonError(f'skeleton {path}: expected an object with a "joints" list')
    names, parent_refs, positions = [], [], []
    for k, joint in enumerate(joints):
        if not isinstance(joint, dict) or not isinstance(joint.get("name"), str) or not joint["name"]:
            raise SkeletonError(f"skeleton {path}: joint #{k} has no name")
        try:
            position = [float(x) for x in joint.get("position")]
        except (TypeError, ValueError, OverflowError):
            position = []
        if len(position) != 3:
            raise SkeletonError(f"skeleton {path}: joint {joint['name']!r}: position must be three numbers")
        names.append(joint["name"])
        parent_refs.append(joint.get("parent"))
        positions.append(position)
    index = {n: i for i, n in enumerate(names)}
    parents = []
    for name, ref in zip(names, parent_refs):
        if ref is None:
            parents.append(-1)
        elif isinstance(ref, str) and ref in index:
            parents.append(index[ref])
        elif isinstance(ref, int) and not isinstance(ref, bool) and -1 <= ref < len(names):
            parents.append(ref)     # autorig's own JSON output: an index, -1 for the root
        else:
            raise SkeletonError(f"skeleton {path}: joint {name!r} has unknown parent {ref!r}")
    return skeleton_from_joints(names, parents, positions, source=str(path), kind="json")


# ------------------------------------------------------------------------------------------------------- BVH

def _from_bvh(data: bytes, path: Path) -> Skeleton:
    from .bvh import parse_bvh

    text = data.decode("utf-8", errors="replace")
    if not any(line.strip() == "MOTION" for line in text.splitlines()):
        text += "\nMOTION\nFrames: 0\nFrame Time: 1\n"    # a hierarchy alone is a skeleton
    try:
        motion = parse_bvh(text, name=f"skeleton {path}")
    except InputError as e:
        raise SkeletonError(str(e)) from None
    positions = motion.rest_positions()
    tips = np.full_like(positions, np.nan)
    for j, offset in motion.end_sites.items():
        tips[j] = positions[j] + offset
    return skeleton_from_joints(motion.names, motion.parents, positions, source=str(path), tips=tips, kind="bvh")


# ------------------------------------------------------------------------------------------------------ glTF

def _from_gltf(data: bytes, path: Path) -> Skeleton:
    import binascii

    try:
        return _gltf_skeleton(data, path)
    except SkeletonError:
        raise
    except (InputError, ValueError, KeyError, IndexError, TypeError, AttributeError, OverflowError, struct.error,
            binascii.Error, OSError, np.linalg.LinAlgError) as e:
        message = str(e).split(": ", 1)[-1] if isinstance(e, InputError) else f"{type(e).__name__}: {e}"
        raise SkeletonError(f"skeleton {path}: cannot read as glTF ({message})") from None


def _gltf_skeleton(data: bytes, path: Path) -> Skeleton:
    from .gltf_parts import buffer_data, joint_parents, node_parents, parse_document, read_accessor, world_matrices

    doc = parse_document(data)
    nodes = doc.nodes or []
    if not doc.skins:
        raise SkeletonError(f"skeleton {path}: the glTF has no skin (no joints to weight)")
    used = [n.skin for n in nodes if n.mesh is not None and n.skin is not None]
    skin = doc.skins[used[0] if used else 0]
    skin_joints = [int(j) for j in skin.joints or []]
    if not skin_joints:
        raise SkeletonError(f"skeleton {path}: the skin has no joints")
    if len(skin_joints) > MAX_JOINTS:  # before the walks below
        raise SkeletonError(f"skeleton {path}: {len(skin_joints):,} joints, more than the {MAX_JOINTS:,} "
                            f"autorig weighs")
    if len(set(skin_joints)) != len(skin_joints) or min(skin_joints) < 0 or max(skin_joints) >= len(nodes):
        raise SkeletonError(f"skeleton {path}: the skin's joints are not distinct nodes")

    children = [c for node in nodes for c in node.children or []]
    if len(set(children)) < len(children):
        twice = next(c for c in children if children.count(c) > 1)
        raise SkeletonError(f"skeleton {path}: node {twice} has two parents")
    node_parent = node_parents(nodes)
    world = world_matrices(nodes, node_parent)   # raises on a cyclic hierarchy
    if skin.inverseBindMatrices is not None:
        buffers = [buffer_data(doc, b, path) for b in doc.buffers]
        inverse_bind = read_accessor(doc, buffers, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
        if len(inverse_bind) != len(skin_joints):
            raise SkeletonError(f"skeleton {path}: {len(inverse_bind)} inverse bind matrices for "
                                f"{len(skin_joints)} joints")
    else:
        # glTF's default bind matrices are identities; writing the inverse world matrices instead binds the
        # mesh in the pose the nodes are in, which is where the joints are read from.
        inverse_bind = np.linalg.inv(world[skin_joints])
    positions = np.linalg.inv(inverse_bind)[:, :3, 3]

    parents = joint_parents(node_parent, skin_joints)
    names = [nodes[n].name or f"node{n}" for n in skin_joints]
    # Order once here so the kept nodes can be listed in the rig's joint order.
    ordered = skeleton_from_joints(names, parents, positions, source=str(path), kind="gltf")
    order = [names.index(n) for n in ordered.names]      # names are distinct: skeleton_from_joints checked
    joint_node_order = [skin_joints[j] for j in order]

    # The non-joint nodes above the joints (an armature node with the file's axis change, a helper between two
    # joints) shape the joints' world transforms, so they are kept; nodes below or beside (meshes, cameras) are
    # not part of the skeleton.
    extra: list[int] = []
    for node in joint_node_order:
        up = node_parent[node]
        while up >= 0:
            if up not in skin_joints and up not in extra:
                extra.append(up)
            up = node_parent[up]
    kept = joint_node_order + sorted(extra)
    new = {node: k for k, node in enumerate(kept)}
    joint_nodes = JointNodes(
        names=[nodes[n].name or f"node{n}" for n in kept],
        transforms=[_transform(nodes[n]) for n in kept],
        children=[[new[c] for c in nodes[n].children or [] if c in new] for n in kept],
        roots=[k for k, n in enumerate(kept) if node_parent[n] < 0],
        inverse_bind=inverse_bind[order],
        skeleton=new.get(skin.skeleton) if skin.skeleton is not None else None,
        skin_name=skin.name or "")
    ordered.joint_nodes = joint_nodes
    return ordered


def _transform(node) -> dict:
    """The node's local transform as the file states it: {"matrix": [16]} or the TRS parts it has."""
    if node.matrix is not None:
        return {"matrix": [float(x) for x in node.matrix]}
    return {key: [float(x) for x in getattr(node, key)] for key in ("translation", "rotation", "scale")
            if getattr(node, key) is not None}
