"""The parts of a glTF document that every reader needs: the file's JSON and binary chunk, its buffers and
accessors as arrays, and its node hierarchy with each node's world transform. Shared by the rig reader
(``gltf``), the look (``gltf_look``) and the skeleton reader (``skeleton``)."""
from __future__ import annotations

import base64
import json
import struct
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pygltflib
from pygltflib import GLTF2, Buffer, Node

from ..errors import InputError
from ..input.confine import Refused, uri_file
from ..input.limits import check_memory, read_regular

_COMPONENT_DTYPES = {
    pygltflib.BYTE: np.int8, pygltflib.UNSIGNED_BYTE: np.uint8,
    pygltflib.SHORT: np.int16, pygltflib.UNSIGNED_SHORT: np.uint16,
    pygltflib.UNSIGNED_INT: np.uint32, pygltflib.FLOAT: np.float32,
}


_TYPE_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


# Component types (5120 BYTE ... 5126 FLOAT; "n": normalized) and types each attribute may have (glTF 2.0,
# 3.7.2.1); KHR_mesh_quantization allows more, below. Anything else is refused: integer positions that are
# not meant as such are a grid of coincident points.
_FLOAT, _UBYTE_N, _USHORT_N = (5126, False), (5121, True), (5123, True)
_ALLOWED = {"POSITION": ({_FLOAT}, {"VEC3"}), "NORMAL": ({_FLOAT}, {"VEC3"}),
            "TEXCOORD": ({_FLOAT, _UBYTE_N, _USHORT_N}, {"VEC2"}),
            "COLOR": ({_FLOAT, _UBYTE_N, _USHORT_N}, {"VEC3", "VEC4"}),
            "JOINTS": ({(5121, False), (5123, False)}, {"VEC4"}),
            "WEIGHTS": ({_FLOAT, _UBYTE_N, _USHORT_N}, {"VEC4"}),
            "indices": ({(5121, False), (5123, False), (5125, False)}, {"SCALAR"})}
_QUANTIZED = {"POSITION": {(c, n) for c in (5120, 5121, 5122, 5123) for n in (False, True)},
              "NORMAL": {(5120, True), (5122, True)},
              "TEXCOORD": {(5120, True), (5122, True), (5120, False), (5121, False), (5122, False), (5123, False)}}
# Extensions that hold the geometry elsewhere, compressed: autorig cannot read them.
COMPRESSION = ("KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_meshopt_compression")


def check_extensions(doc) -> None:
    """Refuse, by name, a document whose geometry is compressed by an extension autorig does not read."""
    named = [e for key in ("extensionsUsed", "extensionsRequired") for e in (getattr(doc, key) or [])
             if isinstance(e, str)]
    for extension in COMPRESSION:
        if extension in named:
            raise ValueError(f"it uses {extension} (compressed geometry), which autorig does not read; export it "
                             f"uncompressed")


def check_attributes(doc, attributes: dict, indices) -> None:
    """Refuse a primitive's attributes whose accessors have a component type or type the attribute does not
    allow, texture coordinate or colour sets not numbered from 0 without gaps (a TEXCOORD_1000000 would make a
    million arrays), or an index accessor of another kind than indices are."""
    quantized = "KHR_mesh_quantization" in (doc.extensionsUsed or [])
    sets: dict[str, list[int]] = {}
    for name, index in [*attributes.items(), *([("indices", indices)] if indices is not None else [])]:
        base, _, number = name.partition("_") if name != "indices" else (name, "", "")
        if base in ("TEXCOORD", "COLOR", "JOINTS", "WEIGHTS"):
            if not number.isdigit() or len(number) > 3:
                raise ValueError(f"attribute {name[:40]}: not a set number autorig reads")
            sets.setdefault(base, []).append(int(number))
        elif name != "indices":
            base = name if name in _ALLOWED else ""
        if not base:
            continue  # application attributes (_FOO), TANGENT: not read
        if not isinstance(index, int) or not 0 <= index < len(doc.accessors or []):
            raise ValueError(f"attribute {name}: no accessor {index}")
        accessor = doc.accessors[index]
        kind = (accessor.componentType, bool(accessor.normalized))
        types, shapes = _ALLOWED[base]
        if kind not in types and not (quantized and kind in _QUANTIZED.get(base, ())):
            raise ValueError(f"{name}: component type {accessor.componentType}"
                             f"{' normalized' if accessor.normalized else ''} is not one glTF allows for it")
        if accessor.type not in shapes:
            raise ValueError(f"{name}: type {str(accessor.type)[:20]} is not one glTF allows for it")
    for base, numbers in sets.items():
        if sorted(numbers) != list(range(len(numbers))):
            raise ValueError(f"{base} sets {sorted(numbers)[:4]}: glTF numbers them from 0 without gaps")


def file_bytes(path: Path) -> bytes:
    try:
        return read_regular(path, None)
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None


def parse_document(data: bytes) -> "_Object":
    """A .glb's or .gltf's JSON as attributes, as pygltflib's classes name them (``doc.nodes[0].mesh``; None
    where absent), with ``binary_blob()`` and ``to_json()``. pygltflib decodes every accessor through
    dataclasses-json, about 2.5 ms each: half a second for a skinned, animated character, more than the rest
    of reading it. Readers only need the JSON."""
    blob = None
    if data[:4] == b"glTF":
        if len(data) < 20:
            raise ValueError("truncated GLB header")
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != 0x4E4F534A:  # "JSON"
            raise ValueError("no JSON chunk")
        text = data[20:20 + length].decode("utf-8")
        start = 20 + length
        if start + 8 <= len(data):
            size, kind = struct.unpack_from("<II", data, start)
            if kind == 0x004E4942:  # "BIN\0"
                blob = data[start + 8:start + 8 + size]
    else:
        text = data.decode("utf-8")
    try:
        document = json.loads(text)
        if not isinstance(document, dict):
            raise ValueError("the JSON is not an object")
        doc = _objects(document)
    except RecursionError:
        raise ValueError("the JSON nests too deeply") from None
    doc.binary_blob = lambda: blob
    doc.to_json = lambda: text
    return doc


class _Object:
    """A JSON object read as attributes; an absent one is None."""

    def __init__(self, fields: dict):
        self.__dict__.update(fields)

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        return None


def _objects(value, key: str = ""):
    # extras and extensions stay plain JSON: they are copied, not read.
    if isinstance(value, dict) and key not in ("extras", "extensions"):
        return _Object({k: _objects(v, k) for k, v in value.items()})
    if isinstance(value, list):
        return [_objects(v) for v in value]
    return value


def node_parents(nodes: list[Node]) -> np.ndarray:
    """[N] the parent node of each of a glTF's nodes, -1 for a scene root."""
    node_parent = np.full(len(nodes), -1)
    for i, node in enumerate(nodes):
        for c in node.children or []:
            node_parent[c] = i
    return node_parent


def root_nodes(node_parent: np.ndarray) -> np.ndarray:
    """[N] the root of each node's tree, each node visited once (a chain of 100,000 nodes walked to its root
    from every node would be 5 billion steps). The hierarchy must have no cycle (``world_matrices`` checks)."""
    root = np.full(len(node_parent), -1)
    for start in range(len(node_parent)):
        chain, n = [], start
        while root[n] < 0 and node_parent[n] >= 0:
            chain.append(n)
            n = node_parent[n]
        top = root[n] if root[n] >= 0 else n
        root[n] = top
        root[chain] = top
    return root


def joint_parents(node_parent: np.ndarray, skin_joints: list[int]) -> np.ndarray:
    """[J] each skin joint's parent joint (an index into ``skin_joints``): its nearest ancestor node that is
    also a joint of the skin, -1 if none (non-joint nodes in between, an armature node above, are skipped)."""
    as_joint = {node: j for j, node in enumerate(skin_joints)}
    above: dict[int, int] = {}  # node -> its nearest joint ancestor's joint index (-1: none), each found once

    def nearest(node: int) -> int:
        chain, up = [], node_parent[node]
        while up >= 0 and up not in as_joint and up not in above:
            chain.append(up)
            up = node_parent[up]
        found = as_joint[up] if up in as_joint else (above[up] if up >= 0 else -1)
        above.update((n, found) for n in chain)
        return found

    return np.array([nearest(node) for node in skin_joints], dtype=np.int64).reshape(-1)


def buffer_data(doc: GLTF2, buffer: Buffer, path: Path, allow_outside: bool = False) -> bytes:
    """The bytes of ``buffer``: the GLB's binary chunk, a data: URI's, or a file's beside ``path`` (confined to
    its folder unless ``allow_outside``: ``autorig.input.confine``), at most ``byteLength`` of them."""
    if buffer.uri is None:
        blob = doc.binary_blob()
        if blob is None:
            raise ValueError("a buffer has no uri and there is no GLB binary chunk")
        return bytes(blob)
    if not isinstance(buffer.uri, str):
        raise ValueError("a buffer's uri is not a string")
    if buffer.uri.startswith("data:"):
        return data_uri_bytes(buffer.uri)
    try:
        file = uri_file(buffer.uri, path.parent, path.parent, allow_outside)
    except Refused as e:
        shown = buffer.uri if len(buffer.uri) <= 200 else buffer.uri[:60] + "..."
        raise InputError(f"{path}: buffer {shown}: {e}") from None
    try:  # a FIFO or a device would never end
        data = read_regular(file)
    except OSError as e:
        raise ValueError(f"buffer {buffer.uri}: {e.strerror or e}") from None
    length = buffer.byteLength if isinstance(buffer.byteLength, int) and buffer.byteLength >= 0 else -1
    return data if length < 0 else data[:length]


def data_uri_bytes(uri: str) -> bytes:
    """The bytes of a base64 ``data:`` URI."""
    if "," not in uri:
        raise ValueError("a data: URI without a comma")
    return base64.b64decode(uri.split(",", 1)[1])


def read_accessor(doc: GLTF2, buffers: list[bytes], index: int) -> np.ndarray:
    """Accessor ``index`` as a [count, components] array: float64 if float or normalized, else int64."""
    accessor = doc.accessors[index]
    dtype = np.dtype(_COMPONENT_DTYPES[accessor.componentType]).newbyteorder("<")
    width = _TYPE_SIZES[accessor.type]
    if not isinstance(accessor.count, int) or accessor.count < 0:
        raise ValueError(f"accessor {index}: a count that is not a whole number")
    if accessor.bufferView is None:
        # All zeros, nothing in the file to hold them: read_gltf_scene checks the counts against max_faces.
        check_memory(accessor.count * width * 8, f"accessor {index}'s {accessor.count:,} zeros", "glTF")
        values = np.zeros((accessor.count, width), dtype=dtype)
    else:
        values = _view_array(doc, buffers, accessor.bufferView, accessor.byteOffset or 0, dtype,
                             accessor.count, width)
    if accessor.sparse is not None:
        sparse = accessor.sparse
        where = _view_array(doc, buffers, sparse.indices.bufferView, sparse.indices.byteOffset or 0,
                            np.dtype(_COMPONENT_DTYPES[sparse.indices.componentType]).newbyteorder("<"),
                            sparse.count, 1)[:, 0]
        values[where.astype(np.int64)] = _view_array(doc, buffers, sparse.values.bufferView,
                                                     sparse.values.byteOffset or 0, dtype, sparse.count, width)
    if dtype.kind == "f":
        return values.astype(np.float64)
    if accessor.normalized:
        # glTF's dequantisation: c / max for unsigned, max(c / max, -1) for signed components.
        return np.maximum(values / np.iinfo(dtype).max, -1.0)
    return values.astype(np.int64)


def _view_array(doc: GLTF2, buffers: list[bytes], view_index: int, offset: int, dtype: np.dtype, count: int,
                width: int) -> np.ndarray:
    view = doc.bufferViews[view_index]
    stride = view.byteStride or dtype.itemsize * width
    if not isinstance(stride, int) or stride < dtype.itemsize * width or stride > 252:
        raise ValueError(f"buffer view {view_index}'s byteStride {stride} overlaps its elements of "
                         f"{dtype.itemsize * width} bytes (or passes glTF's 252)")
    start = (view.byteOffset or 0) + offset
    if count < 0 or offset < 0 or stride < 0 or (view.byteOffset or 0) < 0:
        raise ValueError(f"a negative count, offset or stride in buffer view {view_index}")
    end = (view.byteOffset or 0) + view.byteLength
    if start > end or (count and start + (count - 1) * stride + dtype.itemsize * width > end):
        raise ValueError(f"an accessor reads past the end of buffer view {view_index}")
    if (view.byteOffset or 0) + view.byteLength > len(buffers[view.buffer]):
        raise ValueError(f"buffer view {view_index} runs past the end of buffer {view.buffer}")
    return np.ndarray((count, width), dtype=dtype, buffer=buffers[view.buffer], offset=start,
                      strides=(stride, dtype.itemsize)).copy()


def _local_matrix(node: Node) -> np.ndarray:
    if node.matrix is not None:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T
    m = np.eye(4)
    if node.rotation is not None:
        x, y, z, w = node.rotation
        m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    if node.scale is not None:
        m[:3, :3] *= np.asarray(node.scale, dtype=np.float64)
    if node.translation is not None:
        m[:3, 3] = node.translation
    return m


def world_matrices(nodes: list[Node], node_parent: np.ndarray) -> np.ndarray:
    """World transform [N, 4, 4] of every node, given each node's parent index (-1 at a root).

    Raises ``ValueError`` if the hierarchy has a cycle, which also keeps later walks up it finite.
    """
    world = np.zeros((len(nodes), 4, 4))
    done = np.zeros(len(nodes), dtype=bool)
    for start in range(len(nodes)):
        chain, n = [], start
        while n >= 0 and not done[n]:
            if len(chain) > len(nodes):
                raise ValueError("the node hierarchy has a cycle")
            chain.append(n)
            n = node_parent[n]
        for n in reversed(chain):
            parent = node_parent[n]
            world[n] = _local_matrix(nodes[n]) if parent < 0 else world[parent] @ _local_matrix(nodes[n])
            done[n] = True
    return world
