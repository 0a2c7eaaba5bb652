"""Limits against hostile sizes (issue 28): tiny files that declare huge counts, counts and offsets past the
bytes present, indices out of range, more faces than --max-faces, more than the memory holds: each ends in
exit 2 and one line, quickly, before anything of the declared size is allocated, and leaves no output."""
from __future__ import annotations

import base64
import json
import struct
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from autorig.input import limits
from autorig.cli import cli

TETRA_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
TETRA = ([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)])


def refused(path: Path, *extra, match: str) -> None:
    """Rigging ``path`` ends in exit 2, one error line containing ``match``, in under 5 s, with no output."""
    out = path.with_name("out.glb")
    start = time.perf_counter()
    result = CliRunner().invoke(cli, [str(path), "-o", str(out), *map(str, extra)], prog_name="autorig")
    assert time.perf_counter() - start < 5
    assert result.exit_code == 2, (result.exit_code, result.stderr, result.exception)
    [line] = result.stderr.splitlines()
    assert line.startswith("autorig: error: ") and match in line, line
    assert not out.exists()


def ply_header(fmt: str, vertices: int, faces: int) -> bytes:
    return (f"ply\nformat {fmt} 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n").encode()


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_a_ply_promising_two_billion_vertices(tmp_path, fmt):
    path = tmp_path / "huge.ply"
    path.write_bytes(ply_header(fmt, 2**31, 4) + bytes(200))
    refused(path, match="element vertex: 2,147,483,648 declared, but the file holds only")


def test_a_ply_of_more_faces_than_max_faces(tmp_path):
    path = tmp_path / "tetra.ply"
    body = b"".join(struct.pack("<3f", *v) for v in TETRA[0])
    body += b"".join(struct.pack("<B3i", 3, *f) for f in TETRA[1])
    path.write_bytes(ply_header("binary_little_endian", 4, 4) + body)
    refused(path, "--max-faces", 3, match="4 faces, more than --max-faces 3")


def test_a_binary_stl_promising_more_triangles_than_it_holds(tmp_path):
    path = tmp_path / "huge.stl"
    path.write_bytes(bytes(80) + struct.pack("<I", 2**31 - 1) + bytes(50 * 3))
    refused(path, match="triangles: 2,147,483,647 declared")


def test_an_off_promising_two_billion_vertices(tmp_path):
    path = tmp_path / "huge.off"
    path.write_text(f"OFF\n{2**31} 4 0\n0 0 0\n")
    refused(path, match="truncated")


def test_an_obj_of_more_faces_than_max_faces(tmp_path):
    path = tmp_path / "tetra.obj"
    path.write_text(TETRA_OBJ)
    refused(path, "--max-faces", 3, match="4 faces, more than --max-faces 3")
    path.write_text(TETRA_OBJ.replace("f 1 3 2", "f 1 3 2 4 3"))   # polygons triangulate into more
    refused(path, "--max-faces", 5, match="6 faces, more than --max-faces 5")


def test_an_index_out_of_range(tmp_path):
    path = tmp_path / "tetra.obj"
    path.write_text(TETRA_OBJ.replace("f 2 3 4", "f 2 3 99"))
    refused(path, match="face indices out of range")


def gltf(tmp_path: Path, change) -> Path:
    """The tetrahedron as a .gltf with an embedded buffer, after ``change(document)``."""
    positions = b"".join(struct.pack("<3f", *v) for v in TETRA[0])
    indices = b"".join(struct.pack("<3I", *f) for f in TETRA[1])
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                      {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 48}],
        "buffers": [{"byteLength": 96, "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(positions + indices).decode()}]}
    change(document)
    path = tmp_path / "tetra.gltf"
    path.write_text(json.dumps(document))
    return path


def test_the_gltf_tetrahedron_is_fine(tmp_path):
    from autorig.input.mesh import load_mesh
    vertices, faces = load_mesh(gltf(tmp_path, lambda d: None))
    assert vertices.shape == (4, 3) and faces.shape == (4, 3)


@pytest.mark.parametrize("change, match", [
    (lambda d: d["accessors"][1].update(count=3 * 2**31), "more than --max-faces"),
    (lambda d: d["accessors"][0].update(count=2**31), "reads past the end of buffer view 0"),
    (lambda d: d["accessors"][0].update(byteOffset=2**40), "reads past the end of buffer view 0"),
    (lambda d: d["bufferViews"][1].update(byteLength=2**40), "runs past the end of buffer 0"),
    (lambda d: d["bufferViews"][0].update(byteOffset=-8), "negative"),
    (lambda d: (d["accessors"][0].pop("bufferView"), d["accessors"][0].update(count=2**45)),
     "more than --max-faces"),  # zeros without a buffer view: counted against --max-faces (issue 42)
    (lambda d: d["accessors"].append({"componentType": 5126, "count": 2**45, "type": "MAT4"})
     or d["meshes"][0]["primitives"][0]["attributes"].update(COLOR_0=2), "more than --max-faces"),
    (lambda d: d["buffers"][0].update(uri="data:application/octet-stream;base64," + "A" * 12), "past the end"),
    (lambda d: d.update(nodes=[{"mesh": 0, "children": [0]}]), "cycle"),
])
def test_a_gltf_declaring_more_than_it_holds(tmp_path, change, match):
    refused(gltf(tmp_path, change), match=match)


def test_gltf_indices_out_of_range(tmp_path):
    def change(document):
        raw = base64.b64decode(document["buffers"][0]["uri"].split(",")[1])
        raw = raw[:48] + struct.pack("<I", 2**30) + raw[52:]
        document["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(raw).decode()
    refused(gltf(tmp_path, change), match="indices point past its vertices")


def test_a_json_nested_too_deeply(tmp_path):
    path = tmp_path / "deep.gltf"
    path.write_text("[" * 100_000 + "]" * 100_000)
    refused(path, match="cannot read as glTF")


def test_a_mesh_too_big_for_the_memory_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = tmp_path / "tetra.obj"
    path.write_text(TETRA_OBJ)
    monkeypatch.setattr(limits, "available_memory", lambda: 1000)
    refused(path, match="GB of memory, and 0.0 GB is available")


def test_a_memory_guard_never_refuses_what_fits():
    available = limits.available_memory()
    assert available is None or available > 0
    limits.check_faces(10_000, limits.MAX_FACES, "mesh")


def test_the_command_lines_default_is_the_librarys():
    from autorig.pipeline import RigOptions, SkinOptions
    option = next(p for p in cli.commands["rig"].params if p.name == "max_faces")
    batch_option = next(p for p in cli.commands["batch"].params if p.name == "max_faces")
    assert option.default == batch_option.default == limits.MAX_FACES == RigOptions().max_faces \
        == SkinOptions().max_faces


def test_a_bvh_nested_too_deeply(tmp_path):
    path = tmp_path / "tetra.obj"
    path.write_text(TETRA_OBJ)
    depth = 20_000
    joints = "".join(f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for k in range(depth))
    (tmp_path / "deep.bvh").write_text("HIERARCHY\nROOT hips\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + joints
                                       + "}\n" * (depth + 1) + "MOTION\nFrames: 0\nFrame Time: 0.04\n")
    result = CliRunner().invoke(cli, [str(path), "--skeleton", str(tmp_path / "deep.bvh")], prog_name="autorig")
    assert result.exit_code == 3, (result.stderr, result.exception)
    [line] = result.stderr.splitlines()
    assert "nests too deeply" in line
