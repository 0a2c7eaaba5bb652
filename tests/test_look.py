"""The input's look carried into the rig: UVs, colours, normals, materials and textures from OBJ+MTL and glTF,
image bytes untouched, the glTF validator happy; seam copies after the input's vertices; Mixamo names."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from gltf_validator import validate
from rig_samples import mannequin_bvh, rigged_mannequin

from autorig.exchange.gltf import read_glb, write_glb
from autorig.input.look import load_look
from autorig.input.mesh import load_mesh
from autorig.result import Rig

TEXTURED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "textured"
# The smallest valid files of each kind: what matters is that their bytes come through unchanged.
PNG = bytes.fromhex("89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c4890000000d49444154789c636"
                    "0f8cf00000301010018dd8db40000000049454e44ae426082")
JPEG = bytes.fromhex("ffd8ffe000104a46494600010100000100010000ffdb004300") + bytes(range(1, 65)) + bytes.fromhex(
    "ffc0000b080001000101011100ffc4001400010000000000000000000000000000000affc40014100100000000000000000000000"
    "000000000ffda0008010100003f00d2cf20ffd9")


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autorig.cli", *map(str, args)], capture_output=True, text=True)


def glb_document(path: Path) -> tuple[pygltflib.GLTF2, bytes]:
    doc = pygltflib.GLTF2().load(str(path))
    return doc, doc.binary_blob()


def accessor(doc, blob, index) -> np.ndarray:
    a = doc.accessors[index]
    view = doc.bufferViews[a.bufferView]
    dtype = {pygltflib.FLOAT: "<f4", pygltflib.UNSIGNED_INT: "<u4", pygltflib.UNSIGNED_BYTE: "u1"}[a.componentType]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a.type]
    return np.frombuffer(blob, dtype=dtype, count=a.count * width,
                         offset=(view.byteOffset or 0) + (a.byteOffset or 0)).reshape(a.count, width)


def image_bytes(doc, blob) -> list[bytes]:
    out = []
    for image in doc.images or []:
        view = doc.bufferViews[image.bufferView]
        out.append(blob[view.byteOffset:view.byteOffset + view.byteLength])
    return out


CUBE_OBJ = """mtllib cube.mtl
o front_half
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
v 5 5 5
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
usemtl painted
f 1/1 4/4 3/3 2/2
f 5/1 6/2 7/3 8/4
f 1/1 2/2 6/3 5/4
o back_half
usemtl photo
f 2/5 3/2 7/3 6/4
f 3/1 4/2 8/3 7/4
usemtl plain
f 4/1 1/2 5/3 8/4
"""
CUBE_MTL = """newmtl painted
Kd 0.8 0.8 0.8
map_Kd -s 1 1 1 textures/paint.png
newmtl photo
Kd 1 0 0
map_Kd photo.jpg
newmtl plain
Kd 0 0.5 1
d 0.5
"""


@pytest.fixture
def cube(tmp_path) -> Path:
    (tmp_path / "textures").mkdir()
    (tmp_path / "textures" / "paint.png").write_bytes(PNG)
    (tmp_path / "photo.jpg").write_bytes(JPEG)
    (tmp_path / "cube.mtl").write_text(CUBE_MTL)
    path = tmp_path / "cube.obj"
    path.write_text(CUBE_OBJ)
    return path


def cube_rig(path: Path) -> Rig:
    """A two-joint rig of the cube, weights by height, with its look."""
    vertices, faces = load_mesh(path)
    up = np.clip(vertices[:, 1:2], 0, 1)
    return Rig(names=["root", "top"], parents=np.array([-1, 0]), joints=np.array([[0.5, 0, 0.5], [0.5, 1, 0.5]]),
               weights=np.hstack([1 - up, up]), vertices=vertices, faces=faces, template="test",
               look=load_look(path, faces))


def test_obj_seams_put_copies_after_the_files_vertices(cube):
    vertices, faces = load_mesh(cube)
    look = load_look(cube, faces)
    V = len(vertices)
    np.testing.assert_array_equal(look.vertex_of[:V], np.arange(V))
    np.testing.assert_array_equal(look.vertex_of[look.faces], faces)
    assert len(look.vertex_of) > V and (look.vertex_of[V:] < V).all()
    # Vertex 0 keeps its first corner's UV (1/1: vt 0 0, v flipped for glTF); vertex 1's first corner is 2/2.
    np.testing.assert_allclose(look.texcoords[0][0], [0, 1])
    np.testing.assert_allclose(look.texcoords[0][1], [1, 1])
    # Every corner of every triangle has the UV that the file gave it.
    vt = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    corners = []
    for line in CUBE_OBJ.splitlines():
        if line.startswith("f "):
            polygon = [int(c.split("/")[1]) - 1 for c in line.split()[1:]]
            corners += [polygon[k] for t in range(1, len(polygon) - 1) for k in (0, t, t + 1)]
    uv = look.texcoords[0][look.faces.reshape(-1)]
    np.testing.assert_allclose(uv, np.column_stack([vt[corners, 0], 1 - vt[corners, 1]]), atol=1e-7)
    assert [p["name"] for p in look.parts] == ["front_half", "back_half"]
    assert [m["name"] for m in look.materials] == ["painted", "photo", "plain"]
    assert look.materials[2]["alphaMode"] == "BLEND" and look.materials[2]["pbrMetallicRoughness"][
        "baseColorFactor"] == [0, 0.5, 1, 0.5]


def test_obj_look_goes_into_the_glb_with_the_image_bytes_untouched(cube, tmp_path):
    rig = cube_rig(cube)
    path = tmp_path / "cube.glb"
    write_glb(rig, path)
    assert validate(path)["errors"] == 0
    doc, blob = glb_document(path)
    assert image_bytes(doc, blob) == [PNG, JPEG]
    assert [i.mimeType for i in doc.images] == ["image/png", "image/jpeg"]
    meshes = {doc.nodes[n].name: doc.meshes[doc.nodes[n].mesh] for n in doc.scenes[0].nodes
              if doc.nodes[n].mesh is not None}
    assert sorted(meshes) == ["back_half", "front_half"]
    assert [p.material for p in meshes["front_half"].primitives] == [0]
    assert [p.material for p in meshes["back_half"].primitives] == [1, 2]
    extras = doc.scenes[0].extras
    V = len(rig.vertices)
    assert extras["autorig_input_vertices"] == V
    np.testing.assert_array_equal(extras["autorig_copies_of"], rig.look.vertex_of[V:])
    # Read back: the vertices (seam copies too), weights and look come back as written.
    back = read_glb(path)
    np.testing.assert_allclose(back.vertices, rig.vertices[rig.look.vertex_of], atol=1e-6)
    np.testing.assert_allclose(back.weights, rig.weights[rig.look.vertex_of], atol=1e-6)
    np.testing.assert_allclose(back.look.texcoords[0], rig.look.texcoords[0])
    assert [i.data for i in back.look.images] == [PNG, JPEG]


def test_a_bare_mesh_has_no_look_and_a_vertex_colour_obj_keeps_its_colours(tmp_path):
    path = tmp_path / "tetra.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    assert load_look(path, load_mesh(path)[1]) is None
    coloured = tmp_path / "coloured.obj"
    coloured.write_text("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 0 0 1 1 1 1\n"
                        "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    look = load_look(coloured, load_mesh(coloured)[1])
    np.testing.assert_array_equal(look.colors[:, :3], [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])


def test_a_look_that_cannot_be_read_is_left_out_and_the_shape_still_rigs(tmp_path):
    path = tmp_path / "bad_uv.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\n"
                    "f 1/1 3/9 2/1\nf 1/1 2/1 4/1\nf 1/1 4/1 3/1\nf 2/1 3/1 4/1\n")
    assert load_look(path, load_mesh(path)[1]) is None


def test_a_gltf_whose_image_file_is_missing_keeps_its_colours_and_its_other_textures(cube, tmp_path):
    from autorig.input.confine import Dropped
    from autorig.exchange.gltf import gltf_bytes, read_gltf_scene
    document = json.loads(gltf_bytes(cube_rig(cube)))
    document["images"][0] = {"uri": "gone.png"}
    path = tmp_path / "missing_image.gltf"
    path.write_text(json.dumps(document))
    vertices, faces, look = read_gltf_scene(path)
    assert [i.data for i in look.images] == [JPEG] and [t["source"] for t in look.textures] == [0]
    assert look.dropped == [Dropped("image 0", "gone.png", "missing file")]
    assert [m["pbrMetallicRoughness"]["baseColorFactor"] for m in look.materials] == [
        [1, 1, 1, 1], [1, 1, 1, 1], [0, 0.5, 1, 0.5]]
    painted, photo, plain = (m["pbrMetallicRoughness"] for m in look.materials)
    assert "baseColorTexture" not in painted and photo["baseColorTexture"]["index"] == 0


@pytest.fixture(scope="module")
def cesium(tmp_path_factory):
    source = TEXTURED / "CesiumMan.glb"
    if not source.is_file():
        pytest.skip("../shared/data/textured is not there")
    out = tmp_path_factory.mktemp("cesium") / "man.glb"
    run = run_cli(source, "-o", out)
    assert run.returncode == 0, run.stderr
    return source, out


def test_gltf_input_keeps_its_look_and_loses_its_old_skin(cesium):
    source, out = cesium
    assert validate(out)["errors"] == 0
    before, before_blob = glb_document(source)
    after, after_blob = glb_document(out)
    assert image_bytes(after, after_blob) == image_bytes(before, before_blob)   # the JPEG, not re-encoded
    assert after.images[0].mimeType == "image/jpeg"
    assert after.materials[0].name == "Cesium_Man-effect"
    assert after.samplers[0].minFilter == before.samplers[0].minFilter
    (primitive,) = after.meshes[after.nodes[after.scenes[0].nodes[-1]].mesh].primitives
    old = before.meshes[0].primitives[0].attributes
    np.testing.assert_array_equal(accessor(after, after_blob, primitive.attributes.TEXCOORD_0),
                                  accessor(before, before_blob, old.TEXCOORD_0))
    # The input's own normals, turned by its root node (z-up to y-up) as the vertices are.
    turn = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])   # n @ turn = (root matrix @ n^T)^T
    np.testing.assert_allclose(accessor(after, after_blob, primitive.attributes.NORMAL),
                               accessor(before, before_blob, old.NORMAL) @ turn, atol=1e-6)
    assert len(after.skins) == 1 and after.nodes[after.skins[0].joints[0]].name == "hips"
    assert any(n.name == "Cesium_Man" for n in after.nodes)


def test_babi_obj_rigs_textured_and_valid(tmp_path):
    source = TEXTURED / "Babi" / "Babi.obj"
    if not source.is_file():
        pytest.skip("../shared/data/textured is not there")
    out = tmp_path / "pig.glb"
    run = run_cli(source, "--template", "quadruped", "-o", out)
    assert run.returncode == 0, run.stderr
    assert validate(out)["errors"] == 0
    doc, blob = glb_document(out)
    assert image_bytes(doc, blob) == [(TEXTURED / "Babi" / "Tex.png").read_bytes()]
    assert doc.materials[0].pbrMetallicRoughness.baseColorTexture.index == 0


def test_pose_keeps_the_look_and_preview_reads_it(cube, tmp_path):
    pytest.importorskip("matplotlib")
    from click.testing import CliRunner

    from autorig.cli import cli
    from test_pose import MOVES, POSES
    from dataclasses import replace

    from autorig.result import Image, Look
    rig = rigged_mannequin()[1]   # shared by other tests: changed only in a copy
    # The mannequin with the cube's look would not fit; give it a look of its own: one UV per vertex.
    V, F = len(rig.vertices), len(rig.faces)
    rig = replace(rig, look=Look(vertex_of=np.arange(V), faces=rig.faces, texcoords=[rig.vertices[:, :2].astype(np.float32)],
                    colors=None, normals=None, face_material=np.zeros(F, dtype=np.int64),
                    face_part=np.zeros(F, dtype=np.int64), parts=[{"name": "body", "extras": {"a": 1}}],
                    materials=[{"name": "skin", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                    textures=[{"source": 0}], samplers=[], images=[Image(JPEG, "image/jpeg", "photo")]))
    rigged, walk, motion = tmp_path / "hero.glb", tmp_path / "walk.glb", tmp_path / "moves.bvh"
    write_glb(rig, rigged)
    motion.write_text(mannequin_bvh(POSES, MOVES))
    done = CliRunner().invoke(cli, ["pose", str(rigged), "-m", str(motion), "-o", str(walk)])
    assert done.exit_code == 0, done.output
    assert validate(walk)["errors"] == 0
    doc, blob = glb_document(walk)
    assert image_bytes(doc, blob) == [JPEG] and doc.materials[0].name == "skin" and doc.animations
    body = next(n for n in doc.nodes if n.name == "body")
    assert body.extras == {"a": 1}
    np.testing.assert_allclose(accessor(doc, blob, doc.meshes[body.mesh].primitives[0].attributes.TEXCOORD_0),
                               rig.look.texcoords[0])
    done = CliRunner().invoke(cli, ["preview", str(walk), "-o", str(tmp_path / "walk.png")])
    assert done.exit_code == 0, done.output
    assert (tmp_path / "walk.png").stat().st_size > 10_000


# ---------------------------------------------------------------------------------------------- Mixamo names

@pytest.fixture(scope="module")
def mannequin_obj(tmp_path_factory) -> Path:
    from autorig.exchange.obj import write_obj
    rig = rigged_mannequin()[1]
    path = tmp_path_factory.mktemp("mixamo") / "hero.obj"
    write_obj(rig.vertices, rig.faces, path)
    return path


def test_mixamo_names_and_pose_still_maps_every_joint(mannequin_obj, tmp_path):
    from test_pose import MOVES, POSES
    out = tmp_path / "hero.glb"
    run = run_cli(mannequin_obj, "--names", "mixamo", "-o", out)
    assert run.returncode == 0, run.stderr
    rig = read_glb(out)
    for name in ("mixamorig:Hips", "mixamorig:Spine", "mixamorig:LeftUpLeg", "mixamorig:LeftLeg",
                 "mixamorig:LeftFoot", "mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:RightHand"):
        assert name in rig.names
    assert all(name.startswith("mixamorig:") for name in rig.names)
    motion = tmp_path / "moves.bvh"
    motion.write_text(mannequin_bvh(POSES, MOVES))
    posed = tmp_path / "posed.obj"
    run = run_cli("pose", out, "-m", motion, "--frame", "1", "-o", posed)
    assert run.returncode == 0, run.stderr
    # The same motion on the template-named rig maps as many joints and moves the mesh the same way.
    plain = tmp_path / "plain.glb"
    assert run_cli(mannequin_obj, "-o", plain).returncode == 0
    plain_run = run_cli("pose", plain, "-m", motion, "--frame", "1", "-o", tmp_path / "plain.obj")
    assert plain_run.returncode == 0
    mapped = run.stdout.split(": ", 1)[1].split(", ")[0]
    assert mapped == plain_run.stdout.split(": ", 1)[1].split(", ")[0] == \
        "drives 19 of the rig's 19 joints (its 5 tips aside)"
    np.testing.assert_allclose(load_mesh(posed)[0], load_mesh(tmp_path / "plain.obj")[0], atol=1e-5)


def test_mixamo_names_for_a_quadruped_are_one_line_before_any_work(mannequin_obj):
    run = run_cli(mannequin_obj, "--template", "quadruped", "--names", "mixamo")
    assert run.returncode == 3 and run.stderr.count("\n") == 1 and "biped" in run.stderr


def test_batch_with_mixamo_names(mannequin_obj, tmp_path):
    assets = tmp_path / "assets"
    assets.mkdir()
    (assets / "hero.obj").write_bytes(mannequin_obj.read_bytes())
    run = run_cli("batch", assets, "-o", tmp_path / "rigged", "--names", "mixamo", "-j", "1")
    assert run.returncode == 0, run.stderr
    assert "mixamorig:LeftUpLeg" in read_glb(tmp_path / "rigged" / "hero.rigged.glb").names


def test_relative_indices_and_mixed_corners_give_the_same_look_as_plain_ones(cube, tmp_path):
    """The vectorised reader takes the usual OBJ, the line-by-line one the rest: they agree."""
    plain = load_look(cube, load_mesh(cube)[1])
    lines, vertices = [], 0
    for line in CUBE_OBJ.splitlines():
        if line.startswith("v "):
            vertices += 1
        if line.startswith("f "):   # v/vt -> relative v, absolute vt
            line = "f " + " ".join(f"{int(c.split('/')[0]) - vertices - 1}/{c.split('/')[1]}" for c in line.split()[1:])
        lines.append(line)
    relative = cube.with_name("relative.obj")
    relative.write_text("\n".join(lines) + "\n")
    look = load_look(relative, load_mesh(relative)[1])
    for name in ("vertex_of", "faces", "face_material", "face_part"):
        np.testing.assert_array_equal(getattr(look, name), getattr(plain, name))
    np.testing.assert_array_equal(look.texcoords[0], plain.texcoords[0])
    assert look.parts == plain.parts and look.materials == plain.materials


def test_obj_look_word_search_is_a_plain_substring_search():
    """The bare-OBJ shortcut looks for "vt ", "vn ", "usemtl" and "mtllib" from each occurrence of their second
    byte: it must answer as ``word in data`` does, wherever and however often the bytes occur."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from autorig.input.look import _contains

    @settings(max_examples=400, deadline=None, derandomize=True, database=None)
    @given(st.lists(st.sampled_from([b"v", b"t", b"n", b" ", b"u", b"se", b"mtl", b"lib", b"\n", b"1.5"]),
                    max_size=40).map(b"".join))
    def same(data):
        for word in (b"vt ", b"vn ", b"usemtl", b"mtllib"):
            assert _contains(data, word) == (word in data)

    same()
