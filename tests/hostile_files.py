"""Hostile input families (issue 42), generated into a folder: each is one small file (or folder) made the way
an attacker would, to be rigged through the command line. ``tests/test_hostile.py`` runs them with their exit
codes and lines checked; ``benchmarks/hostile.py`` runs each in a process of its own and measures its time and
memory.

    for name, make in FAMILIES.items():
        args, exits = make(Path(folder) / name)     # the command line after "autorig", the exit codes allowed
"""
from __future__ import annotations

import base64
import json
import os
import struct
from pathlib import Path

import numpy as np

# A 1x1 PNG.
PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg==")


def _box(n: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """A closed tall box, tessellated: vertices [V, 3], faces [F, 3] (a mesh that rigs or fails cleanly)."""
    import trimesh
    shape = trimesh.creation.box((0.4, 1.8, 0.3))
    shape = shape.subdivide().subdivide()
    return np.asarray(shape.vertices, dtype=np.float64), np.asarray(shape.faces, dtype=np.int64)


def good_obj(folder: Path, name: str = "good.obj") -> Path:
    """A mannequin that rigs (``autorig.samples``), as an OBJ."""
    from autorig.samples import mannequin
    sample = mannequin(resolution=24)
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in sample.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in sample.faces]
    path = folder / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _gltf(vertices: np.ndarray, faces: np.ndarray, **changes) -> dict:
    """A minimal glTF document (one buffer, a data: URI) of a mesh; ``changes`` replace top-level keys."""
    positions = np.asarray(vertices, dtype="<f4").tobytes()
    indices = np.asarray(faces, dtype="<u4").tobytes()
    blob = positions + indices
    lo, hi = np.asarray(vertices).min(0).tolist(), np.asarray(vertices).max(0).tolist()
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "body"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
                       "min": lo, "max": hi},
                      {"bufferView": 1, "componentType": 5125, "count": faces.size, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
                        {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices)}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]}
    document.update(changes)
    return document


def _write_gltf(folder: Path, document: dict | str, name: str = "hostile.gltf") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(document if isinstance(document, str) else json.dumps(document))
    return path


def _rig(path: Path, *extra: str) -> list[str]:
    return [str(path), "-o", str(path.parent / "out.glb"), *extra]


def _gltf_family(change, exits=frozenset({2})):
    """A family: the box as glTF, then ``change(document, folder)`` applied."""
    def make(folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        V, F = _box()
        document = _gltf(V, F)
        document = change(document, folder) or document
        return _rig(_write_gltf(folder, document)), set(exits)
    return make


def _buffers_number(d, folder):
    d["buffers"] = 5


def _buffer_nul(d, folder):
    d["buffers"].append({"byteLength": 4, "uri": "a\0b.bin"})


def _nested(d, folder):
    return '{"asset": {"version": "2.0"}, "extras": ' + "[" * 10_000 + "]" * 10_000 + "}"


def _as_list(d, folder):
    return "[" + json.dumps(d) + "]"


def _texcoord(n):
    def change(d, folder):
        d["accessors"].append({"bufferView": 0, "componentType": 5126, "count": d["accessors"][0]["count"],
                               "type": "VEC2"})
        d["meshes"][0]["primitives"][0]["attributes"][f"TEXCOORD_{n}"] = 2
    return change


def _byte_positions(d, folder):
    """POSITION as unsigned bytes (not allowed without KHR_mesh_quantization): a grid of coincident points."""
    V, F = _box()
    q = np.clip(np.round((V - V.min(0)) / np.ptp(V, axis=0) * 4), 0, 255).astype(np.uint8)
    q = np.hstack([q, np.zeros((len(q), 1), np.uint8)])   # 4-byte aligned elements
    blob = q.tobytes() + F.astype("<u4").tobytes()
    d["accessors"][0].update(componentType=5121)
    d["bufferViews"][0].update(byteLength=len(q.tobytes()), byteStride=4)
    d["bufferViews"][1].update(byteOffset=len(q.tobytes()))
    d["buffers"][0] = {"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                       + base64.b64encode(blob).decode()}


def _short_normalized(d, folder):
    _byte_positions(d, folder)
    d["accessors"][0].update(componentType=5122, normalized=True, count=d["accessors"][0]["count"] // 2)
    d["bufferViews"][0].pop("byteStride")


def _overlapping_stride(d, folder):
    d["bufferViews"][0]["byteStride"] = 4     # VEC3 float elements of 12 bytes, 4 apart


def _draco(d, folder):
    d["extensionsUsed"] = d["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    d["accessors"][0] = {"componentType": 5126, "count": 100_000_000, "type": "VEC3"}
    d["accessors"][1] = {"componentType": 5125, "count": 300_000_000, "type": "SCALAR"}
    d["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}


def _no_view(d, folder):
    d["accessors"][0] = {"componentType": 5126, "count": 100_000_000, "type": "VEC3"}


def _node_chain(count):
    def change(d, folder):
        nodes = [{"children": [i + 1], "name": f"n{i}"} for i in range(count - 1)] + [{"mesh": 0, "name": "body"}]
        d["nodes"] = nodes
        d["scenes"] = [{"nodes": [0]}]
    return change


def _scale_overflow(d, folder):
    d["nodes"][0]["scale"] = [1e308, 1e308, 1e308]


def _offset_2e63(d, folder):
    """An empty accessor at an offset no integer of the machine holds (found by tests/test_fuzz_hostile.py)."""
    d["accessors"][0].update(count=0, byteOffset=2**63)


def _nan_positions(d, folder):
    V, F = _box()
    V[5] = np.nan
    d.update(_gltf(V, F))


def _image_uri_int(d, folder):
    d["images"] = [{"uri": 5}]
    d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    d["meshes"][0]["primitives"][0]["material"] = 0


def _images_300(d, folder):
    (folder / "skin.png").write_bytes(PNG + b"\0" * 2_000_000)
    d["images"] = [{"uri": "skin.png"} for _ in range(300)]
    d["textures"] = [{"source": i} for i in range(300)]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": i}}} for i in range(300)]
    d["meshes"][0]["primitives"][0]["material"] = 299


def _image_fifo(d, folder):
    os.mkfifo(folder / "skin.png")
    d["images"] = [{"uri": "skin.png"}]
    d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    d["meshes"][0]["primitives"][0]["material"] = 0


def _image_device(d, folder):
    os.mknod(folder / "skin.png", 0o600 | 0o020000, os.makedev(1, 5))   # /dev/zero's numbers
    _image_fifo_like(d)


def _image_fifo_like(d):
    d["images"] = [{"uri": "skin.png"}]
    d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    d["meshes"][0]["primitives"][0]["material"] = 0


def _escape_uri(d, folder):
    d["buffers"].append({"byteLength": 4, "uri": "\x1b[2J\x1b[Hgone.bin"})


def _obj_family(text_of, name="hostile.obj", exits=frozenset({2})):
    """A family: the box as OBJ, its text passed through ``text_of(text, folder, vertices)``."""
    def make(folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        V, F = _box()
        lines = [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in V] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
        text = text_of("\n".join(lines) + "\n", folder, len(V))
        path = folder / name
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        return _rig(path), set(exits)
    return make


def _mtl_with(map_line):
    def text_of(obj, folder, n):
        (folder / "m.mtl").write_text(f"newmtl skin\nKd 0.8 0.6 0.5\n{map_line}\n")
        return "mtllib m.mtl\nusemtl skin\n" + obj
    return text_of


def _fifo_texture(obj, folder, n):
    os.mkfifo(folder / "skin.png")
    return _mtl_with("map_Kd skin.png")(obj, folder, n)


def _fifo_mtl(obj, folder, n):
    os.mkfifo(folder / "m.mtl")
    return "mtllib m.mtl\nusemtl skin\n" + obj


def _device_mtl(obj, folder, n):
    os.mknod(folder / "m.mtl", 0o600 | 0o020000, os.makedev(1, 5))
    return "mtllib m.mtl\nusemtl skin\n" + obj


def _mtl_2000(obj, folder, n):
    (folder / "m.mtl").write_text("newmtl skin\nKd 0.8 0.6 0.5\n" + "map_Kd skin.png\n")
    (folder / "skin.png").write_bytes(PNG)
    return "mtllib m.mtl\n" * 2000 + "usemtl skin\n" + obj


def _big_face(obj, folder, n):
    corners = np.random.default_rng(1).integers(1, n + 1, 1_000_000)
    return obj + "f " + " ".join(map(str, corners)) + "\n"


def _huge_index(obj, folder, n):
    return obj + "f 1 2 99999999999999999999999\n"


def _blank_vertex(obj, folder, n):
    """A "v" line without numbers before the vertices, with a material: the look counted it, the mesh did not
    (found by tests/test_fuzz_hostile.py)."""
    (folder / "m.mtl").write_text("newmtl skin\nKd 0.8 0.6 0.5\n")
    return "mtllib m.mtl\nusemtl skin\nv   \n" + obj


def _nan_vertex(obj, folder, n):
    return "v nan 0 0\n" + obj.replace("f ", "f ", 1)


def _soup(triangles, points, seed=0):
    def make(folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        rng = np.random.default_rng(seed)
        V = rng.random((points, 3))
        F = rng.integers(0, points, (triangles, 3))
        F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])]
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in V] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
        path = folder / "soup.obj"
        path.write_text("\n".join(lines) + "\n")
        return _rig(path), {0, 5}
    return make


def _off_family(text_of):
    def make(folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        V, F = _box()
        path = folder / "hostile.off"
        path.write_text(text_of(V, F))
        return _rig(path), {2}
    return make


def _off_big_face(V, F):
    corners = np.random.default_rng(1).integers(0, len(V), 1_000_000)
    return (f"OFF\n{len(V)} {len(F) + 1} 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in V)
            + "".join(f"3 {a} {b} {c}\n" for a, b, c in F) + f"{len(corners)} " + " ".join(map(str, corners)) + "\n")


def _off_huge_index(V, F):
    return (f"OFF\n{len(V)} {len(F)} 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in V)
            + "".join(f"3 {a} {b} {c}\n" for a, b, c in F[:-1]) + "3 0 1 99999999999999999999999\n")


def _skeleton_family(write):
    def make(folder: Path):
        mesh = good_obj(folder)
        skeleton = write(folder)
        return _rig(mesh, "--skeleton", str(skeleton)), {2, 3}
    return make


def _random_joints(folder):
    rng = np.random.default_rng(0)
    joints = [{"name": "j0", "parent": None, "position": [0, 0.5, 0]}]
    joints += [{"name": f"j{i}", "parent": f"j{int(rng.integers(0, i))}", "position": rng.random(3).tolist()}
               for i in range(1, 10_000)]
    path = folder / "skeleton.json"
    path.write_text(json.dumps({"joints": joints}))
    return path


def _soup_with_random_joints(folder: Path):
    """A 2,000-triangle soup weighted for 1,000 random joints: the bone heat's planning alone ran 132 s."""
    _soup(2000, 1000, seed=3)(folder)
    rng = np.random.default_rng(4)
    joints = [{"name": "j0", "parent": None, "position": [0.5, 0.5, 0.5]}]
    joints += [{"name": f"j{i}", "parent": f"j{int(rng.integers(0, i))}", "position": rng.random(3).tolist()}
               for i in range(1, 1000)]
    (folder / "skeleton.json").write_text(json.dumps({"joints": joints}))
    return _rig(folder / "soup.obj", "--skeleton", str(folder / "skeleton.json")), {0, 5}


def _position_1e400(folder):
    """A joint at an integer too large for a float (found by tests/test_fuzz_hostile.py)."""
    path = folder / "skeleton.json"
    path.write_text(json.dumps({"joints": [{"name": "a", "parent": None, "position": [10**400, 0, 0]},
                                           {"name": "b", "parent": "a", "position": [0, 1, 0]}]}))
    return path


def _position_1e308(folder):
    """A joint at 1e308, finite but beyond what squared distances hold (found by tests/test_fuzz_hostile.py)."""
    path = folder / "skeleton.json"
    path.write_text(json.dumps({"joints": [{"name": "a", "parent": None, "position": [0, 0, 1e308]},
                                           {"name": "b", "parent": "a", "position": [0, 1, 0]}]}))
    return path


def _nested_skeleton(folder):
    path = folder / "skeleton.json"
    path.write_text('{"joints": ' + "[" * 100_000 + "]" * 100_000 + "}")
    return path


def _flat_gltf_skeleton(folder):
    count = 30_000
    nodes = [{"name": f"j{i}", "translation": [0, 1e-3 * i, 0]} for i in range(count)]
    nodes[0]["children"] = list(range(1, count))
    ibm = np.tile(np.eye(4, dtype="<f4").reshape(1, 16), (count, 1)).tobytes()
    document = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": nodes,
                "skins": [{"joints": list(range(count)), "inverseBindMatrices": 0}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": "MAT4"}],
                "bufferViews": [{"buffer": 0, "byteLength": len(ibm)}],
                "buffers": [{"byteLength": len(ibm),
                             "uri": "data:application/octet-stream;base64," + base64.b64encode(ibm).decode()}]}
    return _write_gltf(folder, document, "skeleton.gltf")


FAMILIES = {
    # glTF structure
    "gltf-buffers-number": _gltf_family(_buffers_number),
    "gltf-buffer-nul": _gltf_family(_buffer_nul),
    "gltf-nested-10000": _gltf_family(_nested),
    "gltf-top-list": _gltf_family(_as_list),
    "gltf-texcoord-1000000": _gltf_family(_texcoord(1_000_000)),
    "gltf-texcoord-10000000": _gltf_family(_texcoord(10_000_000)),
    "gltf-byte-positions": _gltf_family(_byte_positions),
    "gltf-short-normalized": _gltf_family(_short_normalized),
    "gltf-overlapping-stride": _gltf_family(_overlapping_stride),
    "gltf-draco-1e8": _gltf_family(_draco),
    "gltf-no-view-1e8": _gltf_family(_no_view),
    "gltf-chain-100000": _gltf_family(_node_chain(100_000), exits={0, 5}),
    "gltf-scale-overflow": _gltf_family(_scale_overflow),
    "gltf-offset-2e63": _gltf_family(_offset_2e63),
    "gltf-nan-position": _gltf_family(_nan_positions),
    "gltf-image-uri-int": _gltf_family(_image_uri_int, exits={0, 5}),
    "gltf-300-images": _gltf_family(_images_300, exits={0, 5}),
    "gltf-image-fifo": _gltf_family(_image_fifo, exits={0, 5}),
    "gltf-image-device": _gltf_family(_image_device, exits={0, 5}),
    "gltf-escape-uri": _gltf_family(_escape_uri),
    # OBJ, OFF
    "obj-fifo-texture": _obj_family(_fifo_texture, exits={0, 5}),
    "obj-fifo-mtl": _obj_family(_fifo_mtl, exits={0, 5}),
    "obj-device-mtl": _obj_family(_device_mtl, exits={0, 5}),
    "obj-mtllib-2000": _obj_family(_mtl_2000, exits={0, 5}),
    "obj-face-1e6-corners": _obj_family(_big_face),
    "obj-huge-index": _obj_family(_huge_index),
    "obj-nan-vertex": _obj_family(_nan_vertex),
    "obj-blank-vertex": _obj_family(_blank_vertex),
    "off-face-1e6-corners": _off_family(_off_big_face),
    "off-huge-index": _off_family(_off_huge_index),
    # pathological shapes
    "soup-600": _soup(600, 300),
    "soup-100": _soup(100, 300, seed=1),
    "soup-2000": _soup(2000, 1000, seed=2),
    "soup-25-sphere-cap": _soup(25, 70, seed=5),      # 1,910 spheres: the orientation's frames at the cap
    # skeletons
    "skeleton-10000-random": _skeleton_family(_random_joints),
    "skeleton-nested-json": _skeleton_family(_nested_skeleton),
    "skeleton-position-1e400": _skeleton_family(_position_1e400),
    "skeleton-position-1e308": _skeleton_family(_position_1e308),
    "skeleton-gltf-flat-30000": _skeleton_family(_flat_gltf_skeleton),
    "skeleton-1000-in-soup": _soup_with_random_joints,
}

# Families that need root (mknod of a character device).
NEEDS_ROOT = {"gltf-image-device", "obj-device-mtl"}
