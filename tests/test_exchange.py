"""Output formats (autorig.exchange): round trips, glTF validity, Pinocchio's bone convention, atomic writes."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pygltflib
import pytest
import trimesh

from autorig.errors import InputError, OutputError
from autorig.exchange import check_output, default_output_path, write_rig
from autorig.exchange.gltf import read_glb, top4_influences
from autorig.exchange.json_format import read_json
from autorig.exchange.pinocchio import bone_weights
from autorig.result import Rig
from gltf_validator import validate



def make_rig(joint_count: int = 5, seed: int = 0) -> Rig:
    """Two crossed cylinders (a body and arms) with a chain of joints and seeded random weights.

    Every vertex gets 1 to 6 nonzero weights, some rows tie exactly, one vertex follows only joint 0 and
    one only the last joint, so top-4 selection, padding and tie-breaking are all exercised.
    """
    body = trimesh.creation.cylinder(radius=0.2, height=2.0, sections=16)
    arms = trimesh.creation.cylinder(radius=0.1, height=1.5, sections=8)
    arms.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    arms.apply_translation([0, 0, 0.6])
    mesh = trimesh.util.concatenate([body, arms])
    rng = np.random.default_rng(seed)
    V, J = len(mesh.vertices), joint_count
    weights = rng.random((V, J)) * (rng.random((V, J)) < 0.6)
    weights[np.arange(V), rng.integers(0, J, V)] += 0.05
    weights[1, :] = 0.0
    weights[1, :min(J, 6)] = 1.0
    weights[2] = np.eye(J)[0]
    weights[3] = np.eye(J)[J - 1]
    weights /= weights.sum(axis=1, keepdims=True)
    parents = np.arange(J) - 1
    if J >= 4:
        parents[J - 1] = 1  # a branch: joint 1 has two children
    joints = np.column_stack([np.linspace(-0.3, 0.3, J), np.zeros(J), np.linspace(-1.0, 1.0, J)])
    return Rig(names=[f"joint_{j}" for j in range(J)], parents=parents, joints=joints, weights=weights,
               vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces, dtype=np.int64),
               template="test", timings={"embed": 0.125, "skin": 2.5},
               info={"axis": np.int64(1), "scale": np.float32(0.5), "penalties": np.array([1.5, np.nan]),
                     "note": "héllo"})


def dense_top4(weights: np.ndarray) -> np.ndarray:
    """The dense [V, J] weights a glTF reader sees: the 4 largest per row, rescaled to sum to 1."""
    out = np.zeros_like(weights)
    for i, row in enumerate(weights):
        keep = sorted(range(len(row)), key=lambda j: (-row[j], j))[:4]
        out[i, keep] = row[keep] / row[keep].sum()
    return out


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


# --- glTF -----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_gltf_round_trip(tmp_path, fmt):
    rig = make_rig()
    path = write_rig(rig, tmp_path / f"rig.{fmt}", fmt)
    back = read_glb(path)
    assert back.names == rig.names
    np.testing.assert_array_equal(back.parents, rig.parents)
    np.testing.assert_allclose(back.joints, rig.joints, atol=1e-6)
    assert back.vertices.shape == rig.vertices.shape
    np.testing.assert_allclose(back.vertices, rig.vertices, atol=1e-6)
    np.testing.assert_array_equal(back.faces, rig.faces)
    np.testing.assert_allclose(back.weights, dense_top4(rig.weights), atol=1e-6)
    np.testing.assert_allclose(back.weights.sum(axis=1), 1.0, atol=1e-12)
    assert back.template == "test"


@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_gltf_records_the_characters_axes(tmp_path, fmt):
    """The axes the character stands on in the file go in the scene's extras and come back as the rig's."""
    from dataclasses import replace
    rig = replace(make_rig(), info={"up": "z", "front": "-y"})
    back = read_glb(write_rig(rig, tmp_path / f"rig.{fmt}", fmt))
    assert back.info == {"up": "z", "front": "-y"}
    assert read_glb(write_rig(make_rig(), tmp_path / f"none.{fmt}", fmt)).info == {}
    # Axes that are not two perpendicular axis names are not taken.
    for axes in ({"up": "z", "front": "-z"}, {"up": "w", "front": "y"}, {"up": 1, "front": "y"}, ["z", "y"]):
        doc = pygltflib.GLTF2().load(str(tmp_path / f"rig.{fmt}"))
        doc.scenes[0].extras = {"autorig_axes": axes}
        doc.save(str(tmp_path / f"bad.{fmt}"))
        assert read_glb(tmp_path / f"bad.{fmt}").info == {}


@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_gltf_passes_khronos_validator(tmp_path, fmt):
    path = write_rig(make_rig(), tmp_path / f"rig.{fmt}", fmt)
    report = validate(path)
    assert report["errors"] == 0, report["messages"]
    assert report["warnings"] == 0, report["messages"]


def test_glb_with_many_joints_uses_uint16_and_validates(tmp_path):
    rig = make_rig(joint_count=300)
    path = write_rig(rig, tmp_path / "rig.glb", "glb")
    doc = pygltflib.GLTF2.load(str(path))
    joints_accessor = doc.accessors[doc.meshes[0].primitives[0].attributes.JOINTS_0]
    assert joints_accessor.componentType == pygltflib.UNSIGNED_SHORT
    back = read_glb(path)
    np.testing.assert_allclose(back.weights, dense_top4(rig.weights), atol=1e-6)
    assert validate(path)["errors"] == 0


def test_glb_structure(tmp_path):
    rig = make_rig()
    doc = pygltflib.GLTF2.load(str(write_rig(rig, tmp_path / "rig.glb", "glb")))
    J = len(rig.names)
    mesh_node = doc.nodes[J]
    assert mesh_node.mesh == 0 and mesh_node.skin == 0
    assert mesh_node.translation is None and mesh_node.rotation is None and mesh_node.matrix is None
    assert sorted(doc.scenes[0].nodes) == [0, J]
    for j in range(J):
        assert doc.nodes[j].rotation is None and doc.nodes[j].scale is None
    primitive = doc.meshes[0].primitives[0]
    assert doc.accessors[primitive.attributes.JOINTS_0].componentType == pygltflib.UNSIGNED_BYTE
    assert primitive.attributes.NORMAL is not None
    assert all(view.byteLength % 4 == 0 and view.byteOffset % 4 == 0 for view in doc.bufferViews)


def test_trimesh_loads_glb_with_same_vertices(tmp_path):
    rig = make_rig()
    mesh = trimesh.load(write_rig(rig, tmp_path / "rig.glb", "glb"), force="mesh", process=False)
    assert len(mesh.vertices) == len(rig.vertices)
    np.testing.assert_allclose(mesh.vertices, rig.vertices, atol=1e-6)


def test_top4_influences_order_ties_and_padding():
    weights = np.array([[0.1, 0.2, 0.2, 0.2, 0.2, 0.1],   # a four-way tie: lowest indices first
                        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],   # one influence: the rest pad with joint 0
                        [0.5, 0.0, 0.0, 0.0, 0.0, 0.5]])
    joints, amounts = top4_influences(weights)
    np.testing.assert_array_equal(joints, [[1, 2, 3, 4], [3, 0, 0, 0], [0, 5, 0, 0]])
    np.testing.assert_allclose(amounts, [[0.25] * 4, [1, 0, 0, 0], [0.5, 0.5, 0, 0]])
    assert amounts.dtype == np.float32


def test_top4_weights_sum_to_one_in_float32():
    rng = np.random.default_rng(1)
    weights = rng.random((2000, 7)) ** 3
    _, amounts = top4_influences(weights / weights.sum(axis=1, keepdims=True))
    assert np.abs(amounts.astype(np.float64).sum(axis=1) - 1.0).max() < 1e-7


def test_read_glb_of_foreign_skinned_file(tmp_path):
    """A hand-built file unlike ours: an armature node with rotation and scale, a joint given by a matrix,
    skin joints listed child first, no inverse bind matrices, normalized ubyte weights, two primitives
    sharing their vertices, and a non-joint node between two joints."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=np.float32)
    joints = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]], dtype=np.uint8)
    weights = np.array([[255, 0, 0, 0], [128, 127, 0, 0], [255, 0, 0, 0], [255, 0, 0, 0]], dtype=np.uint8)
    first, second = np.array([0, 1, 2], dtype=np.uint16), np.array([2, 1, 3], dtype=np.uint16)
    blob = b"".join(a.tobytes() for a in (positions, joints, weights, first, second))
    offsets = np.cumsum([0, 48, 16, 16, 6, 6])
    views = [pygltflib.BufferView(buffer=0, byteOffset=int(o), byteLength=int(n))
             for o, n in zip(offsets[:-1], np.diff(offsets))]
    accessors = [
        pygltflib.Accessor(bufferView=0, componentType=pygltflib.FLOAT, count=4, type="VEC3"),
        pygltflib.Accessor(bufferView=1, componentType=pygltflib.UNSIGNED_BYTE, count=4, type="VEC4"),
        pygltflib.Accessor(bufferView=2, componentType=pygltflib.UNSIGNED_BYTE, count=4, type="VEC4",
                           normalized=True),
        pygltflib.Accessor(bufferView=3, componentType=pygltflib.UNSIGNED_SHORT, count=3, type="SCALAR"),
        pygltflib.Accessor(bufferView=4, componentType=pygltflib.UNSIGNED_SHORT, count=3, type="SCALAR"),
    ]
    attributes = dict(POSITION=0, JOINTS_0=1, WEIGHTS_0=2)
    quarter_turn_z = [0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]
    shift = np.eye(4)
    shift[:3, 3] = [0, 0, 3]
    nodes = [
        pygltflib.Node(name="Armature", rotation=quarter_turn_z, scale=[2, 2, 2], children=[1]),
        pygltflib.Node(name="hips", translation=[1, 0, 0], children=[2]),
        pygltflib.Node(name="helper", matrix=shift.T.ravel().tolist(), children=[3]),
        pygltflib.Node(name="head", translation=[0, 1, 0]),
        pygltflib.Node(name="body", mesh=0, skin=0),
    ]
    doc = pygltflib.GLTF2(
        scene=0, scenes=[pygltflib.Scene(nodes=[0, 4])], nodes=nodes,
        meshes=[pygltflib.Mesh(primitives=[pygltflib.Primitive(attributes=pygltflib.Attributes(**attributes),
                                                               indices=i) for i in (3, 4)])],
        skins=[pygltflib.Skin(name="found", joints=[3, 1])],
        accessors=accessors, bufferViews=views, buffers=[pygltflib.Buffer(byteLength=len(blob))])
    doc.set_binary_blob(blob)
    path = tmp_path / "foreign.glb"
    path.write_bytes(b"".join(doc.save_to_bytes()))

    rig = read_glb(path)
    assert rig.names == ["hips", "head"]
    np.testing.assert_array_equal(rig.parents, [-1, 0])
    # Armature: scale 2 then a quarter turn about z, so local (x, y, z) lands at (-2y, 2x, 2z).
    np.testing.assert_allclose(rig.joints, [[0, 2, 0], [-2, 2, 6]], atol=1e-9)
    np.testing.assert_allclose(rig.vertices, positions)
    np.testing.assert_array_equal(rig.faces, [[0, 1, 2], [2, 1, 3]])
    # skin joint 0 is "head" (now column 1), skin joint 1 is "hips" (now column 0)
    np.testing.assert_allclose(rig.weights, [[1, 0], [127 / 255, 128 / 255], [0, 1], [1, 0]], atol=1e-9)


def test_read_glb_errors(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        read_glb(tmp_path / "missing.glb")
    (tmp_path / "junk.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(InputError, match="junk.glb"):
        read_glb(tmp_path / "junk.glb")
    plain = trimesh.creation.box()
    plain.export(tmp_path / "plain.glb")
    with pytest.raises(InputError, match="no skinned mesh"):
        read_glb(tmp_path / "plain.glb")


# --- Pinocchio ------------------------------------------------------------------------------------------

def test_pinocchio_files(tmp_path):
    rig = make_rig()
    folder = write_rig(rig, tmp_path / "rig.rigged", "pinocchio")
    assert sorted(os.listdir(folder)) == ["attachment.out", "joint_names.txt", "skeleton.out"]
    skeleton = np.loadtxt(folder / "skeleton.out", ndmin=2)
    np.testing.assert_array_equal(skeleton[:, 0], np.arange(len(rig.names)))
    np.testing.assert_allclose(skeleton[:, 1:4], rig.joints, rtol=1e-8, atol=1e-12)
    np.testing.assert_array_equal(skeleton[:, 4], rig.parents)
    attachment = np.loadtxt(folder / "attachment.out", ndmin=2)
    assert attachment.shape == (len(rig.vertices), len(rig.names) - 1)
    np.testing.assert_allclose(attachment.sum(axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(attachment, bone_weights(rig.weights, rig.parents), atol=1e-6)
    names = (folder / "joint_names.txt").read_text().splitlines()
    assert names == [f"{j} {name}" for j, name in enumerate(rig.names)]


def test_pinocchio_bone_convention():
    # 0 -> 1 -> 2 (tip) and 0 -> 3 (tip): bones are 0->1 (column 0), 1->2 (column 1), 0->3 (column 2).
    parents = np.array([-1, 0, 1, 0])
    weights = np.array([[1.0, 0.0, 0.0, 0.0],    # the root's weight is shared by its two bones
                        [0.0, 1.0, 0.0, 0.0],    # joint 1 owns only bone 1->2
                        [0.2, 0.0, 0.5, 0.3]])   # tips' weights stay on the bones ending at them
    np.testing.assert_allclose(bone_weights(weights, parents),
                               [[0.5, 0.0, 0.5], [0.0, 1.0, 0.0], [0.1, 0.5, 0.4]])
    with pytest.raises(ValueError):
        bone_weights(weights, np.array([-1, 0, -1, 0]))


def test_pinocchio_replaces_only_its_own_folder(tmp_path):
    rig = make_rig()
    folder = tmp_path / "out"
    write_rig(rig, folder, "pinocchio")
    (folder / "skeleton.out").write_text("stale")
    write_rig(rig, folder, "pinocchio")
    assert (folder / "skeleton.out").read_text().startswith("0 ")
    assert leftovers(tmp_path) == []

    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "thesis.tex").write_text("keep me")
    with pytest.raises(OutputError, match="holds other files"):
        write_rig(rig, precious, "pinocchio")
    assert os.listdir(precious) == ["thesis.tex"]

    (tmp_path / "a_file").write_text("x")
    with pytest.raises(OutputError, match="not a folder"):
        write_rig(rig, tmp_path / "a_file", "pinocchio")
    assert leftovers(tmp_path) == []


# --- JSON -----------------------------------------------------------------------------------------------

def test_json_round_trip(tmp_path):
    rig = make_rig()
    path = write_rig(rig, tmp_path / "rig.json", "json")
    document = json.loads(path.read_text(encoding="utf-8"))
    assert [j["name"] for j in document["joints"]] == rig.names
    assert document["info"] == {"axis": 1, "note": "héllo", "penalties": [1.5, None], "scale": 0.5}
    assert document["timings"] == {"embed": 0.125, "skin": 2.5}
    back = read_json(path)
    assert back.names == rig.names and back.template == "test"
    np.testing.assert_array_equal(back.parents, rig.parents)
    np.testing.assert_allclose(back.joints, rig.joints, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(back.weights, rig.weights, atol=1e-6)
    np.testing.assert_allclose(back.weights.sum(axis=1), 1.0, atol=1e-5)
    assert back.vertices.shape == (0, 3)


def test_read_json_errors(tmp_path):
    (tmp_path / "other.json").write_text('{"hello": 1}')
    with pytest.raises(InputError, match="not an autorig rig file"):
        read_json(tmp_path / "other.json")
    (tmp_path / "broken.json").write_text("{")
    with pytest.raises(InputError, match="not JSON"):
        read_json(tmp_path / "broken.json")


# --- All formats: paths, determinism, atomicity ---------------------------------------------------------

FORMATS = ["glb", "gltf", "pinocchio", "json"]


def output_bytes(path: Path) -> dict[str, bytes]:
    if path.is_dir():
        return {p.name: p.read_bytes() for p in sorted(path.iterdir())}
    return {"": path.read_bytes()}


@pytest.mark.parametrize("fmt", FORMATS)
def test_same_rig_same_bytes(tmp_path, fmt):
    first = write_rig(make_rig(), tmp_path / f"a.{fmt}", fmt)
    second = write_rig(make_rig(), tmp_path / f"b.{fmt}", fmt)
    assert output_bytes(first) == output_bytes(second)


def test_default_output_path():
    assert default_output_path("/m/hero.obj", "glb") == Path("/m/hero.rigged.glb")
    assert default_output_path("/m/hero.obj", "gltf") == Path("/m/hero.rigged.gltf")
    assert default_output_path("/m/hero.obj", "pinocchio") == Path("/m/hero.rigged")
    assert default_output_path("hero.v2.off", "json") == Path("hero.v2.rigged.json")
    with pytest.raises(OutputError, match="unknown output format"):
        default_output_path("hero.obj", "abc")
    with pytest.raises(OutputError, match="unknown output format"):
        write_rig(make_rig(), "hero.abc", "abc")


@pytest.mark.parametrize("fmt", FORMATS)
def test_missing_directory_raises_and_leaves_nothing(tmp_path, fmt):
    target = tmp_path / "nowhere" / "rig.out"
    with pytest.raises(OutputError, match="does not exist") as caught:
        write_rig(make_rig(), target, fmt)
    assert str(target) in str(caught.value) and "\n" not in str(caught.value)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("fmt", ["glb", "gltf", "json"])
def test_existing_file_is_replaced(tmp_path, fmt):
    target = tmp_path / "rig.out"
    target.write_bytes(b"old")
    write_rig(make_rig(), target, fmt)
    assert target.read_bytes() != b"old"
    assert sorted(os.listdir(tmp_path)) == ["rig.out"]


@pytest.mark.parametrize("fmt", ["glb", "gltf", "json"])
def test_directory_as_file_path_raises(tmp_path, fmt):
    (tmp_path / "dir").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        write_rig(make_rig(), tmp_path / "dir", fmt)
    assert os.listdir(tmp_path) == ["dir"] and os.listdir(tmp_path / "dir") == []


@pytest.mark.parametrize("fmt", FORMATS)
def test_failed_rename_keeps_old_output_and_leaves_no_temp(tmp_path, fmt, monkeypatch):
    target = tmp_path / "rig.out"
    write_rig(make_rig(seed=1), target, fmt)
    before = output_bytes(target)

    def refuse(*args):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "replace", refuse)
    monkeypatch.setattr(os, "rename", refuse)
    with pytest.raises(OutputError, match="permission denied"):
        write_rig(make_rig(seed=2), target, fmt)
    monkeypatch.undo()
    assert output_bytes(target) == before
    assert os.listdir(tmp_path) == ["rig.out"]


def test_pinocchio_puts_old_folder_back_if_new_one_cannot_take_its_place(tmp_path, monkeypatch):
    folder = tmp_path / "out"
    write_rig(make_rig(seed=1), folder, "pinocchio")
    before = output_bytes(folder)
    rename = os.rename
    calls = []

    def second_rename_fails(source, destination):
        calls.append(source)
        if len(calls) == 2:  # the first moved the old output aside; the second would move the new one in
            raise OSError(28, "No space left on device")
        rename(source, destination)

    monkeypatch.setattr(os, "rename", second_rename_fails)
    with pytest.raises(OutputError, match="no space left on device"):
        write_rig(make_rig(seed=2), folder, "pinocchio")
    monkeypatch.undo()
    assert len(calls) == 3
    assert output_bytes(folder) == before
    assert os.listdir(tmp_path) == ["out"]


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a non-root POSIX user")
def test_read_only_directory_raises(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        with pytest.raises(OutputError, match="permission denied"):
            write_rig(make_rig(), locked / "rig.glb", "glb")
        assert os.listdir(locked) == []
    finally:
        locked.chmod(0o755)


def test_check_output_refuses_early_what_write_rig_would_refuse(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    mesh = tmp_path / "hero.obj"
    mesh.write_text("v 0 0 0")
    check_output(tmp_path / "hero.rigged.glb", "glb", input_path=mesh)
    check_output(tmp_path / "hero.rigged", "pinocchio", input_path=mesh)
    for path, fmt, reason in [(tmp_path / "sub", "pinocchio", "holds other files"),
                              (tmp_path, "pinocchio", "overwrite the input"),
                              (tmp_path / "none" / "a.glb", "glb", "does not exist"),
                              (tmp_path / "sub", "json", "is a directory"),
                              (tmp_path / "a.abc", "abc", "unknown output format")]:
        (tmp_path / "sub").mkdir(exist_ok=True)
        (tmp_path / "sub" / "x").write_text("x")
        with pytest.raises(OutputError, match=reason):
            check_output(path, fmt, input_path=mesh)


def test_never_overwrites_the_input(tmp_path):
    mesh = tmp_path / "hero.glb"
    mesh.write_bytes(b"the user's mesh")
    with pytest.raises(OutputError, match="overwrite the input"):
        write_rig(make_rig(), mesh, "glb", input_path=mesh)
    with pytest.raises(OutputError, match="overwrite the input"):
        write_rig(make_rig(), tmp_path, "pinocchio", input_path=mesh)
    os.link(mesh, tmp_path / "alias.glb")
    with pytest.raises(OutputError, match="overwrite the input"):
        write_rig(make_rig(), tmp_path / "alias.glb", "glb", input_path=mesh)
    assert mesh.read_bytes() == b"the user's mesh"
