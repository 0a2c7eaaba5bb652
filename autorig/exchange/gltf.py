"""glTF 2.0 with a skin: :func:`write_glb` / :func:`write_gltf` write a :class:`Rig`, :func:`read_glb` reads one
back from any skinned glTF or GLB.

What is written (node index = joint index, so the file reads back in the rig's own order):

- nodes ``0 .. J-1``: the joints, named by joint name, nested as ``rig.parents`` says; each has
  ``translation`` = its offset from its parent joint (its position for the root) and no rotation or scale;
- node ``J``: the mesh node, at the scene root with no transform (a skinned mesh ignores its own node's
  transform, so the validator warns about any);
- one mesh, one triangle primitive: ``POSITION`` (float32, the input vertices in input order and count),
  ``NORMAL`` (float32, area-weighted vertex normals), ``indices`` (uint32), ``JOINTS_0`` (uint8, or uint16
  past 256 joints) and ``WEIGHTS_0`` (float32): each vertex's 4 strongest joints, see :func:`top4_influences`;
- one skin over all joints, named after the template, whose ``inverseBindMatrices`` translate by minus each
  joint's position (the bind pose is the rest pose the rig was built in).

A rig with a look (``rig.look``: the input's UVs, colours, normals, materials, textures) is written on the
look's vertices instead (the input's vertices, then the seam copies), with ``TEXCOORD_n`` and ``COLOR_0``, the
input's normals where it had them, one mesh node per input mesh, one primitive per material, and the images
byte for byte in the buffer (:mod:`autorig.exchange.gltf_look`); the scene's ``extras`` say which input vertex
each seam copy stands for (``autorig_input_vertices``, ``autorig_copies_of``).

A rig re-weighted on a glTF's own skeleton (``rig.joint_nodes``, from ``autorig MESH --skeleton rig.glb``) keeps
that file's joints instead: nodes ``0 .. J-1`` are its joints with their names and local transforms (matrix or
TRS) as the file had them, then the non-joint nodes above them, then the mesh node; the skin has the file's
inverse bind matrices, name and ``skeleton`` node.
"""
from __future__ import annotations

import base64
import binascii
import os
import re
import struct
from pathlib import Path

import numpy as np
import pygltflib
from pygltflib import (GLTF2, Accessor, Asset, Attributes, Buffer, BufferView, Mesh, Node, Primitive, Scene,
                       Skin)

from ..errors import InputError
from ..input.facing import face_cross
from ..input.limits import check_faces
from ..result import Look, Rig
from ..version import __version__
from .arrays import check_rig, parents_first
from .files import write_file_atomic
from .gltf_look import gather_primitives, look_of, write_look
from .gltf_parts import (buffer_data, file_bytes, joint_parents, node_parents, parse_document, read_accessor,
                         check_extensions, root_nodes, world_matrices)

__all__ = ["write_glb", "write_gltf", "glb_bytes", "gltf_bytes", "read_glb", "read_gltf_scene",
           "top4_influences", "vertex_normals"]


def write_glb(rig: Rig, path: str | os.PathLike) -> None:
    """Write ``rig`` as a binary glTF (``.glb``) file, atomically; ``OutputError`` if it cannot be written."""
    write_file_atomic(path, glb_bytes(rig))


def write_gltf(rig: Rig, path: str | os.PathLike) -> None:
    """Write ``rig`` as one self-contained ``.gltf`` JSON file (the buffer embedded as a base64 data URI)."""
    write_file_atomic(path, gltf_bytes(rig))


def glb_bytes(rig: Rig) -> bytes:
    """The ``.glb`` file for ``rig``; the same rig always gives the same bytes."""
    doc, blob = _document(rig)
    doc.set_binary_blob(blob)
    return b"".join(doc.save_to_bytes())


def gltf_bytes(rig: Rig) -> bytes:
    """The self-contained ``.gltf`` file for ``rig``; the same rig always gives the same bytes."""
    doc, blob = _document(rig)
    doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
    return doc.gltf_to_json(indent=1).encode("utf-8") + b"\n"


def top4_influences(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The up-to-4 joints that move each vertex, as glTF's ``JOINTS_0`` / ``WEIGHTS_0`` store them.

    weights  [V, J] skin weights (rows >= 0, each with some positive weight)
    returns  joints [V, 4] int64, the 4 largest weights' joint indices, strongest first, ties to the lower
             index; weights [V, 4] float32, those weights rescaled to sum to 1. A slot whose weight is 0
             (fewer than 4 influences) holds joint 0.

    The strongest weight is stored as 1 minus the other three (summed in float64), so the float32 row sums
    to 1 within half a float32 ulp, well inside the validator's tolerance.
    """
    weights = np.asarray(weights, dtype=np.float64)
    V, J = weights.shape
    joints = np.zeros((V, 4), dtype=np.int64)
    top = np.zeros((V, 4), dtype=np.float64)
    k = min(4, J)
    joints[:, :k] = np.argsort(-weights, axis=1, kind="stable")[:, :k]
    top[:, :k] = np.take_along_axis(weights, joints[:, :k], axis=1)
    total = top.sum(axis=1)
    if np.any(total <= 0):
        raise ValueError(f"vertex {int(np.argmax(total <= 0))} has no skin weight")
    top32 = (top / total[:, None]).astype(np.float32)
    top32[:, 0] = 1.0 - top32[:, 1:].astype(np.float64).sum(axis=1)
    joints[top32 == 0] = 0
    return joints, top32


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit area-weighted vertex normals [V, 3] float32 of the mesh ``vertices`` [V, 3], ``faces`` [F, 3].

    A vertex whose normal is undefined (used by no face, or whose faces cancel out) gets +Z: glTF requires
    every normal to be unit length.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    face_normals = face_cross(vertices, faces)   # np.cross's values
    normals = np.stack([np.bincount(faces.ravel(), weights=np.repeat(face_normals[:, c], 3),
                                    minlength=len(vertices)) for c in range(3)], axis=1)
    length = np.linalg.norm(normals, axis=1)
    defined = np.isfinite(length) & (length > 0)
    normals[defined] /= length[defined, None]
    normals[~defined] = (0.0, 0.0, 1.0)
    return normals.astype(np.float32)


def _document(rig: Rig) -> tuple[GLTF2, bytes]:
    """The glTF document for ``rig`` and its one binary buffer (referenced as buffer 0, no uri yet)."""
    check_rig(rig)
    J = len(rig.names)
    parents = np.asarray(rig.parents, dtype=np.int64)
    joints = np.asarray(rig.joints, dtype=np.float64)
    vertices = np.asarray(rig.vertices, dtype=np.float64)
    faces = np.asarray(rig.faces, dtype=np.int64)

    look = rig.look
    # With a look the file's vertices are the look's (seam copies after the input's vertices, see Look).
    copy = np.asarray(look.vertex_of) if look is not None else slice(None)
    influences, influence_weights = top4_influences(rig.weights)
    influences, influence_weights = influences[copy], influence_weights[copy]
    joint_dtype = np.uint8 if J <= 256 else np.uint16
    if rig.joint_nodes is None:
        ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
        ibm[:, :3, 3] = -joints
    else:
        ibm = np.asarray(rig.joint_nodes.inverse_bind, dtype=np.float32)
    positions = vertices[copy].astype(np.float32)

    blob = bytearray()
    views: list[BufferView] = []
    accessors: list[Accessor] = []

    def add(array: np.ndarray, component: int, kind: str, target: int | None, **extra) -> int:
        # Every array here is a whole number of 4-byte words, so each view starts 4-aligned as glTF wants.
        data = np.ascontiguousarray(array).astype(array.dtype.newbyteorder("<")).tobytes()
        views.append(BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data), target=target))
        blob.extend(data)
        accessors.append(Accessor(bufferView=len(views) - 1, componentType=component, count=len(array),
                                  type=kind, **extra))
        return len(accessors) - 1

    position = add(positions, pygltflib.FLOAT, "VEC3", pygltflib.ARRAY_BUFFER,
                   min=[float(x) for x in positions.min(axis=0)], max=[float(x) for x in positions.max(axis=0)])
    normals = look.normals if look is not None and look.normals is not None else vertex_normals(vertices, faces)[copy]
    normal = add(np.asarray(normals, dtype=np.float32), pygltflib.FLOAT, "VEC3", pygltflib.ARRAY_BUFFER)
    if look is None:
        indices = add(faces.astype(np.uint32).reshape(-1), pygltflib.UNSIGNED_INT, "SCALAR",
                      pygltflib.ELEMENT_ARRAY_BUFFER)
    joint_slots = add(influences.astype(joint_dtype),
                      pygltflib.UNSIGNED_BYTE if joint_dtype == np.uint8 else pygltflib.UNSIGNED_SHORT, "VEC4",
                      pygltflib.ARRAY_BUFFER)
    weight_slots = add(influence_weights, pygltflib.FLOAT, "VEC4", pygltflib.ARRAY_BUFFER)
    # glTF matrices are column-major: store each transpose row by row.
    inverse_bind = add(ibm.transpose(0, 2, 1).reshape(J, 16), pygltflib.FLOAT, "MAT4", None)

    source = rig.joint_nodes
    if source is None:
        nodes = []
        for j, name in enumerate(rig.names):
            offset = joints[j] - joints[parents[j]] if parents[j] >= 0 else joints[j]
            nodes.append(Node(name=str(name), translation=[float(x) for x in offset],
                              children=[int(c) for c in np.flatnonzero(parents == j)]))
        roots = [int(r) for r in np.flatnonzero(parents < 0)]
        skeleton_root = roots[0] if len(roots) == 1 else None
    else:
        # Re-weighted on a glTF's own skeleton: its nodes, transforms and bind pose go back as they were.
        nodes = [Node(name=name, children=list(children), **transform)
                 for name, transform, children in zip(source.names, source.transforms, source.children)]
        roots, skeleton_root = list(source.roots), source.skeleton
    meshes, scene_extras = [], {}
    if look is None:
        mesh_nodes = [len(nodes)]
        nodes.append(Node(name="mesh", mesh=0, skin=0))
        meshes.append(Mesh(name="mesh", primitives=[Primitive(
            attributes=Attributes(POSITION=position, NORMAL=normal, JOINTS_0=joint_slots, WEIGHTS_0=weight_slots),
            indices=indices, mode=pygltflib.TRIANGLES)]))
    doc = GLTF2(
        asset=Asset(version="2.0", generator=f"autorig {__version__}"),
        scene=0,
        scenes=[Scene(nodes=roots)],
        nodes=nodes,
        meshes=meshes,
        skins=[Skin(name=(source.skin_name if source else "") or rig.template or "skin",
                    inverseBindMatrices=inverse_bind, joints=list(range(J)), skeleton=skeleton_root)],
        accessors=accessors,
        bufferViews=views,
        buffers=[Buffer(byteLength=len(blob))],
    )
    if look is not None:
        def add_bytes(data: bytes) -> int:
            views.append(BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
            blob.extend(data + b"\0" * (-len(data) % 4))  # the next view starts 4-aligned again
            return len(views) - 1

        attributes = {"POSITION": position, "NORMAL": normal, "JOINTS_0": joint_slots, "WEIGHTS_0": weight_slots}
        mesh_nodes = write_look(doc, look, add, add_bytes, attributes, skin=0)
        scene_extras = dict(look.extras)
        if len(copy) > len(vertices):
            # Which input vertex each seam copy (output vertex V, V+1, ...) stands for; see Look.
            scene_extras.update(autorig_input_vertices=len(vertices),
                                autorig_copies_of=[int(v) for v in copy[len(vertices):]])
    if rig.info.get("dropped"):
        # What of the input's look could not come along (autorig.input.confine), for whoever opens the file.
        scene_extras["autorig_dropped"] = rig.info["dropped"]
    if rig.info.get("up") and rig.info.get("front"):
        # The axes the character stands on in this file (given or detected): glTF assumes +y up and +z front,
        # so a Z-up scan's rig would be drawn and posed lying down by whoever reads it without them
        # (``autorig preview``, ``autorig pose``).
        scene_extras["autorig_axes"] = {"up": str(rig.info["up"]), "front": str(rig.info["front"])}
    if rig.info.get("hands"):
        # Which hands got fingers (autorig.hands): {"left": "fingers", "right": "mitten"}.
        scene_extras["autorig_hands"] = rig.info["hands"]
    doc.scenes[0].nodes = roots + mesh_nodes
    doc.scenes[0].extras = scene_extras or None
    doc.buffers[0].byteLength = len(blob)
    return doc, bytes(blob)


def read_glb(path: str | os.PathLike) -> Rig:
    """Read the skinned mesh of a ``.glb`` or ``.gltf`` file as a :class:`Rig` (raises ``InputError``).

    Reads autorig's own output back exactly (up to float32), and other skinned glTF too: node hierarchies
    with TRS or matrix transforms, several primitives, any number of ``JOINTS_n``/``WEIGHTS_n`` sets,
    normalized integer weights, strided and sparse accessors, external or embedded buffers.

    The first skin used by a mesh node is read; every triangle primitive of every mesh node using that skin
    is gathered into one mesh (primitives sharing their vertex data share their vertices). Vertices are
    in the skinned mesh's own (bind) space; joint positions are in that same space: taken from the inverse
    bind matrices (the joint's bind-pose origin), or from the nodes' world transforms when the skin has
    none. Joints are reordered, if needed, so parents come before children; a joint's parent is its nearest
    ancestor node that is also a joint of the skin. Weight rows are rescaled to sum to 1.
    """
    path = Path(path)
    data = file_bytes(path)
    try:
        return _read(path, data)
    except (ValueError, KeyError, IndexError, TypeError, AttributeError, OverflowError, struct.error,
            binascii.Error, OSError) as e:
        raise InputError(f"cannot read {path} as glTF: {e}") from None


def _read(path: Path, data: bytes) -> Rig:
    doc = parse_document(data)
    buffers = [buffer_data(doc, b, path) for b in doc.buffers]
    nodes = doc.nodes or []

    skinned = [i for i, n in enumerate(nodes) if n.mesh is not None and n.skin is not None]
    if not skinned:
        raise InputError(f"{path} has no skinned mesh")
    skin_index = nodes[skinned[0]].skin
    skin = doc.skins[skin_index]
    skin_joints = list(skin.joints)
    J = len(skin_joints)

    node_parent = node_parents(nodes)
    world = world_matrices(nodes, node_parent)  # also rejects cyclic hierarchies before the walks below
    if skin.inverseBindMatrices is not None:
        ibm = read_accessor(doc, buffers, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
        positions = np.linalg.inv(ibm)[:, :3, 3]
    else:
        positions = world[skin_joints][:, :3, 3]

    mesh_nodes = [i for i in skinned if nodes[i].skin == skin_index]
    gathered = gather_primitives(doc, buffers, mesh_nodes, None, J, read_accessor)
    vertices, faces, weights = gathered.vertices, gathered.faces, gathered.weights

    parents = joint_parents(node_parent, skin_joints)
    order, parents = parents_first(parents)

    total = weights.sum(axis=1, keepdims=True)
    weights = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)
    names = [nodes[skin_joints[j]].name or f"joint_{j}" for j in order]
    return Rig(names=names, parents=parents, joints=positions[order], weights=weights[:, order],
               vertices=vertices, faces=faces, template=skin.name or "", info=recorded_axes(doc),
               look=look_of(doc, buffers, gathered, mesh_nodes, path) if _has_look(doc, gathered) else None)


def recorded_axes(doc: GLTF2) -> dict:
    """{"up": axis, "front": axis} as autorig recorded them in the scene's extras (``autorig_axes``), or {}
    for a file without them or with axes that are not two perpendicular axis names."""
    scenes = doc.scenes or []
    scene = scenes[doc.scene if isinstance(doc.scene, int) and 0 <= doc.scene < len(scenes) else 0] if scenes else None
    axes = scene.extras.get("autorig_axes") if scene is not None and isinstance(scene.extras, dict) else None
    if not isinstance(axes, dict) or not all(isinstance(axes.get(k), str) for k in ("up", "front")):
        return {}
    # ``mesh.axis_vector``'s spelling ('x', '+y', '-z'), checked here since ``mesh`` reads glTF through us.
    specs = [a.strip().lower() for a in (axes["up"], axes["front"])]
    if not all(re.fullmatch(r"[+-]?[xyz]", a) for a in specs) or specs[0][-1] == specs[1][-1]:
        return {}
    return {"up": axes["up"], "front": axes["front"]}


def read_gltf_scene(path: str | os.PathLike, allow_outside: bool = False, max_faces: int | None = None,
                    look: bool = True) -> tuple[np.ndarray, np.ndarray, Look | None]:
    """A glTF or GLB file as a mesh to rig: (vertices [V, 3], faces [F, 3], its ``Look`` or None).

    The scene is flattened: each mesh node's primitives are moved by the node's world transform, and the
    nodes are taken in order of their names (a node without one is called by its index), ties in node order;
    a node's primitives in their order, those sharing their vertex accessors sharing their vertices. Points
    and lines are ignored. Raises ``InputError`` (one line naming the file) for anything unreadable, for
    buffer files outside its folder unless ``allow_outside`` (``autorig.input.confine``), and for more triangles
    than ``max_faces`` (None: no limit) or than the memory holds, checked before they are read. Without
    ``look`` the look is not read (None).
    """
    path = Path(path)
    data = file_bytes(path)
    try:
        doc = parse_document(data)
        check_extensions(doc)
        buffers = [buffer_data(doc, b, path, allow_outside) for b in doc.buffers or []]
        nodes = doc.nodes or []
        node_parent = node_parents(nodes)
        world = world_matrices(nodes, node_parent)
        in_scene = _scene_nodes(doc, node_parent)
        mesh_nodes = sorted((i for i in in_scene if nodes[i].mesh is not None),
                            key=lambda i: (nodes[i].name or str(i), i))
        if not mesh_nodes:
            raise InputError(f"{path}: no mesh found (empty, or not a valid glTF file)")
        check_faces(_declared_triangles(doc, mesh_nodes), max_faces, str(path))
        try:
            gathered = gather_primitives(doc, buffers, mesh_nodes, world[mesh_nodes], 0, read_accessor)
        except ValueError as e:
            if str(e) == "no triangles":
                raise InputError(f"{path}: a point cloud or lines (no faces); autorig needs a surface mesh") from None
            raise
        look = (look_of(doc, buffers, gathered, mesh_nodes, path, allow_outside=allow_outside)
                if look and _has_look(doc, gathered, normals=True) else None)
    except InputError:
        raise
    except (ValueError, KeyError, IndexError, TypeError, AttributeError, OverflowError, struct.error,
            binascii.Error, OSError, UnicodeDecodeError) as e:
        message = " ".join(str(e).split())[:150] or type(e).__name__
        raise InputError(f"{path}: cannot read as glTF ({message})") from None
    return gathered.vertices, gathered.faces, look


def _declared_triangles(doc: GLTF2, mesh_nodes: list[int]) -> int:
    """The triangles the mesh nodes' triangle primitives declare (their index or vertex counts / 3)."""
    total = 0
    for node in mesh_nodes:
        for primitive in doc.meshes[doc.nodes[node].mesh].primitives or []:
            if primitive.mode in (None, pygltflib.TRIANGLES):
                source = primitive.indices if primitive.indices is not None else primitive.attributes.POSITION
                total += int(doc.accessors[source].count) // 3
                # Vertices too: an accessor without a buffer view is zeros of any count the file says.
                total = max(total, max((int(doc.accessors[a].count) // 3 for a in vars(primitive.attributes).values()
                                        if isinstance(a, int) and 0 <= a < len(doc.accessors)
                                        and doc.accessors[a].bufferView is None), default=0))
    return total


def _scene_nodes(doc: GLTF2, node_parent: np.ndarray) -> list[int]:
    """The nodes of the document's scene (all nodes when it names no scene)."""
    if not doc.scenes:
        return list(range(len(doc.nodes or [])))
    roots = set(doc.scenes[doc.scene or 0].nodes or [])
    top = root_nodes(node_parent)
    return [i for i in range(len(doc.nodes or [])) if int(top[i]) in roots]


def _has_look(doc: GLTF2, gathered, normals: bool = False) -> bool:
    """Whether there is more to keep than the shape: UVs, colours, materials (or, with ``normals``, normals:
    an input's own are kept, while a rig's read back are only autorig's, which it computes again)."""
    return bool(gathered.texcoords or gathered.colors is not None or doc.materials
                or (normals and gathered.normals is not None))


