"""``autorig MESH --skeleton FILE``: skin weights for the user's own skeleton (JSON, glTF, BVH).

The project's mannequin (data/) is the character; the artists' rigs in ../shared/data are scored with
../shared/tools/score.py when they are there, and skipped otherwise.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest
import trimesh

import autorig
from autorig.weights.bones import plan_heat
from autorig.errors import SkeletonError
from autorig.exchange.gltf import read_glb
from autorig.exchange.skeleton import read_skeleton
from autorig.input.mesh import load_mesh
from gltf_validator import validate

ROOT = Path(__file__).resolve().parents[1]
MANNEQUIN = ROOT / "data" / "mannequin.obj"
MANNEQUIN_JOINTS = ROOT / "data" / "mannequin.joints.json"
SHARED = ROOT.parent / "shared"
RIGGED = SHARED / "data" / "rigged"


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autorig.cli", *map(str, args)], capture_output=True, text=True)


def check_weights(weights: np.ndarray, vertex_count: int) -> None:
    """Every vertex weighted, rows >= 0 summing to 1."""
    assert weights.shape[0] == vertex_count
    assert weights.min() >= 0
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-5)


@pytest.fixture(scope="module")
def mannequin_skin(tmp_path_factory):
    """The mannequin weighted on its own joints through the command line: (output .glb, stdout)."""
    out = tmp_path_factory.mktemp("json") / "man.glb"
    run = run_cli(MANNEQUIN, "--skeleton", MANNEQUIN_JOINTS, "-o", out)
    assert run.returncode == 0, run.stderr
    return out, run.stdout


# --- JSON ------------------------------------------------------------------------------------------------------

def test_json_skeleton_keeps_the_joints_and_weights_every_vertex(mannequin_skin):
    out, stdout = mannequin_skin
    assert "24 joints" in stdout and str(out) in stdout
    rig = read_glb(out)
    V, _ = load_mesh(MANNEQUIN)
    np.testing.assert_allclose(rig.vertices, V, atol=1e-6)          # the input's vertices, in their order
    check_weights(rig.weights, len(V))
    given = {j["name"]: j for j in json.loads(MANNEQUIN_JOINTS.read_text())["joints"]}
    assert sorted(rig.names) == sorted(given)
    for name, position in zip(rig.names, rig.joints):
        np.testing.assert_allclose(position, given[name]["position"], atol=1e-6)
        parent = rig.parents[rig.names.index(name)]
        assert (rig.names[parent] if parent >= 0 else None) == given[name]["parent"]
    # The "_end" joints sit at the body's ends: tips with no weight. The wrists carry the hands.
    column = {n: rig.weights[:, i] for i, n in enumerate(rig.names)}
    for tip in ("head_end", "left_hand_end", "right_hand_end", "left_toe_end", "right_toe_end"):
        assert column[tip].max() == 0, tip
    hand = int(np.argmin(np.linalg.norm(V - given["left_hand_end"]["position"], axis=1)))
    assert rig.names[int(np.argmax(rig.weights[hand]))] == "left_wrist"
    forearm = (np.asarray(given["left_elbow"]["position"]) + given["left_wrist"]["position"]) / 2
    near = int(np.argmin(np.linalg.norm(V - forearm, axis=1)))
    assert rig.names[int(np.argmax(rig.weights[near]))] == "left_elbow"


def test_autorig_json_output_reads_as_a_skeleton(mannequin_skin, tmp_path):
    rigged = tmp_path / "man.json"
    assert run_cli(MANNEQUIN, "--skeleton", MANNEQUIN_JOINTS, "-o", rigged, "-q").returncode == 0
    again = tmp_path / "again.json"
    run = run_cli(MANNEQUIN, "--skeleton", rigged, "-o", again, "-q")
    assert run.returncode == 0, run.stderr
    first, second = json.loads(rigged.read_text()), json.loads(again.read_text())
    assert first["joints"] == second["joints"] and first["weights"] == second["weights"]


# --- glTF ------------------------------------------------------------------------------------------------------

def test_glb_reweight_round_trip_keeps_the_rig(mannequin_skin, tmp_path):
    """--skeleton on a .glb re-weights it: same nodes, names, transforms and bind matrices; a valid file."""
    source, _ = mannequin_skin
    out = tmp_path / "again.glb"
    run = run_cli(MANNEQUIN, "--skeleton", source, "-o", out)
    assert run.returncode == 0, run.stderr
    a, b = pygltflib.GLTF2.load(str(source)), pygltflib.GLTF2.load(str(out))
    assert [(n.name, n.translation, n.rotation, n.scale, n.children) for n in a.nodes] == \
           [(n.name, n.translation, n.rotation, n.scale, n.children) for n in b.nodes]
    before, after = read_glb(source), read_glb(out)
    np.testing.assert_allclose(after.joints, before.joints, atol=1e-6)
    np.testing.assert_allclose(after.weights, before.weights, atol=1e-4)
    assert validate(out)["errors"] == 0


def armature_glb(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A Blender-style export of the mannequin's skeleton: the joints under a non-joint "Armature" node that turns
    z-up centimetres into y-up metres, joints with rotations, a joint stacked on its parent (a zero-length bone),
    a camera node under a joint. Returns the mesh (vertices, faces) the skin is bound to (metres, y-up)."""
    skeleton = read_skeleton(MANNEQUIN_JOINTS)
    V, F = load_mesh(MANNEQUIN)
    names = list(skeleton.names) + ["hips_helper"]
    parents = np.append(skeleton.parents, 0)                           # stacked on the hips
    world = np.vstack([skeleton.positions, skeleton.positions[0]])
    armature = np.array([[0.01, 0, 0, 0], [0, 0, 0.01, 0], [0, -0.01, 0, 0], [0, 0, 0, 1]])  # x 0.01, -90 about x
    turn = trimesh.transformations.rotation_matrix(0.3, [0, 1, 0])      # every joint turned about its own y
    matrices = []
    for j, p in enumerate(parents):
        m = turn.copy()
        m[:3, 3] = world[j]
        matrices.append(m)
    locals_ = [np.linalg.inv(matrices[p] if p >= 0 else armature) @ matrices[j] for j, p in enumerate(parents)]
    nodes = []
    for j, name in enumerate(names):
        q = trimesh.transformations.quaternion_from_matrix(locals_[j])   # w, x, y, z
        nodes.append(pygltflib.Node(name=name, translation=[float(x) for x in locals_[j][:3, 3]],
                                    rotation=[float(q[1]), float(q[2]), float(q[3]), float(q[0])],
                                    children=[int(c) for c in np.flatnonzero(parents == j)]))
    J = len(names)
    nodes[0].children.append(J + 1)
    nodes.append(pygltflib.Node(name="Armature", rotation=[-0.7071067811865476, 0, 0, 0.7071067811865476],
                                scale=[0.01, 0.01, 0.01], children=[0]))
    nodes.append(pygltflib.Node(name="camera_mount", translation=[0.0, 10.0, 0.0]))
    nodes.append(pygltflib.Node(name="body", mesh=0, skin=0))
    ibm = np.linalg.inv(np.array(matrices)).astype(np.float32)
    positions = V.astype(np.float32)
    joints0 = np.zeros((len(V), 4), np.uint8)
    weights0 = np.zeros((len(V), 4), np.float32)
    weights0[:, 0] = 1
    blobs = [positions.tobytes(), F.astype(np.uint32).tobytes(), joints0.tobytes(), weights0.tobytes(),
             ibm.transpose(0, 2, 1).reshape(J, 16).tobytes()]
    views, offset = [], 0
    for blob in blobs:
        views.append(pygltflib.BufferView(buffer=0, byteOffset=offset, byteLength=len(blob)))
        offset += len(blob)
    accessors = [
        pygltflib.Accessor(bufferView=0, componentType=pygltflib.FLOAT, count=len(V), type="VEC3",
                           min=positions.min(axis=0).tolist(), max=positions.max(axis=0).tolist()),
        pygltflib.Accessor(bufferView=1, componentType=pygltflib.UNSIGNED_INT, count=F.size, type="SCALAR"),
        pygltflib.Accessor(bufferView=2, componentType=pygltflib.UNSIGNED_BYTE, count=len(V), type="VEC4"),
        pygltflib.Accessor(bufferView=3, componentType=pygltflib.FLOAT, count=len(V), type="VEC4"),
        pygltflib.Accessor(bufferView=4, componentType=pygltflib.FLOAT, count=J, type="MAT4")]
    doc = pygltflib.GLTF2(
        asset=pygltflib.Asset(version="2.0"), scene=0, scenes=[pygltflib.Scene(nodes=[J, J + 2])], nodes=nodes,
        meshes=[pygltflib.Mesh(primitives=[pygltflib.Primitive(
            attributes=pygltflib.Attributes(POSITION=0, JOINTS_0=2, WEIGHTS_0=3), indices=1)])],
        skins=[pygltflib.Skin(name="Armature", joints=list(range(J)), inverseBindMatrices=4, skeleton=J)],
        accessors=accessors, bufferViews=views, buffers=[pygltflib.Buffer(byteLength=offset)])
    doc.set_binary_blob(b"".join(blobs))
    doc.save(str(path))
    return V, F


def test_glb_with_armature_node_and_stacked_joints(tmp_path):
    source = tmp_path / "exported.glb"
    V, F = armature_glb(source)
    skeleton = read_skeleton(source)
    expected = read_skeleton(MANNEQUIN_JOINTS)
    np.testing.assert_allclose(skeleton.positions[:len(expected.names)], expected.positions, atol=1e-5)
    mesh = tmp_path / "body.obj"
    trimesh.Trimesh(V, F, process=False).export(mesh)
    out = tmp_path / "body.rigged.glb"
    run = run_cli(mesh, "--skeleton", source, "-o", out)
    assert run.returncode == 0, run.stderr
    a, b = pygltflib.GLTF2.load(str(source)), pygltflib.GLTF2.load(str(out))
    by_name = {n.name: n for n in b.nodes}
    for node in a.nodes[:-2]:                  # the joints and the Armature (not the camera mount or the mesh)
        kept = by_name[node.name]
        assert (kept.translation, kept.rotation, kept.scale) == (node.translation, node.rotation, node.scale)
        assert sorted(b.nodes[c].name for c in kept.children) == \
               sorted(a.nodes[c].name for c in node.children if a.nodes[c].name != "camera_mount")
    assert b.nodes[b.skins[0].skeleton].name == "Armature" and b.skins[0].name == "Armature"
    rig = read_glb(out)
    source_ibm = read_glb(source).joints
    order = [read_glb(source).names.index(n) for n in rig.names]
    np.testing.assert_allclose(rig.joints, source_ibm[order], atol=1e-6)
    check_weights(rig.weights, len(V))
    assert rig.weights[:, rig.names.index("hips_helper")].max() == 0     # a zero-length bone heats nothing
    assert validate(out)["errors"] == 0


# --- BVH -------------------------------------------------------------------------------------------------------

def bvh_text(skeleton, scale: float, shift) -> str:
    """A BVH hierarchy (no motion) of ``skeleton`` in other units and placed elsewhere; leaves get End Sites at
    their own position (zero offset), which autorig treats like any leaf without a bone."""
    lines = ["HIERARCHY"]
    P = skeleton.positions * scale + np.asarray(shift)

    def joint(j, depth):
        pad = "  " * depth
        offset = P[j] - (P[skeleton.parents[j]] if skeleton.parents[j] >= 0 else 0)
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {skeleton.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        lines.append(f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")
        children = np.flatnonzero(skeleton.parents == j)
        for c in children:
            joint(int(c), depth + 1)
        if len(children) == 0:
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET 0 0 0")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    joint(0, 0)
    return "\n".join(lines) + "\nMOTION\nFrames: 1\nFrame Time: 0.0333\n" + " ".join(["0"] * 3 * len(P)) + "\n"


def test_bvh_rest_pose_is_fitted_to_the_mesh(tmp_path, mannequin_skin):
    truth = read_skeleton(MANNEQUIN_JOINTS)
    bvh = tmp_path / "man.bvh"
    bvh.write_text(bvh_text(truth, 1 / 0.0254, [40.0, -3.0, 7.0]))           # inches, somewhere else
    out = tmp_path / "man.glb"
    run = run_cli(MANNEQUIN, "--skeleton", bvh, "-o", out, "-q")
    assert run.returncode == 0, run.stderr
    rig = read_glb(out)
    check_weights(rig.weights, len(load_mesh(MANNEQUIN)[0]))
    height = 1.70
    fitted = {n: p for n, p in zip(rig.names, rig.joints)}
    errors = [np.linalg.norm(fitted[n] - p) / height for n, p in zip(truth.names, truth.positions)]
    assert max(errors) < 0.03, errors                  # bounding boxes of joints and mesh differ by the flesh
    # Given the scale, the positions are the file's times that scale, and the weights those of the JSON skeleton.
    bvh.write_text(bvh_text(truth, 1 / 0.0254, [0.0, 0.0, 0.0]))
    exact = tmp_path / "exact.glb"
    assert run_cli(MANNEQUIN, "--skeleton", bvh, "--skeleton-scale", "0.0254", "-o", exact, "-q").returncode == 0
    rig, reference = read_glb(exact), read_glb(mannequin_skin[0])
    order = [reference.names.index(n) for n in rig.names]                 # a BVH lists its joints depth first
    np.testing.assert_allclose(rig.joints, reference.joints[order], atol=1e-5)
    np.testing.assert_allclose(rig.weights, reference.weights[:, order], atol=1e-4)


# --- bad input -------------------------------------------------------------------------------------------------

BAD_SKELETONS = {
    "missing.json": None,
    "not_json.json": "{joints: [",
    "no_joints.json": '{"joints": []}',
    "not_a_list.json": '{"joints": 3}',
    "cycle.json": '{"joints": [{"name": "a", "parent": "b", "position": [0, 0, 0]},'
                  ' {"name": "b", "parent": "a", "position": [0, 1, 0]}]}',
    "unknown_parent.json": '{"joints": [{"name": "a", "parent": "z", "position": [0, 0, 0]}]}',
    "bad_index.json": '{"joints": [{"name": "a", "parent": 5, "position": [0, 0, 0]}]}',
    "nan.json": '{"joints": [{"name": "a", "parent": null, "position": [0, NaN, 0]}]}',
    "short_position.json": '{"joints": [{"name": "a", "parent": null, "position": [0, 1]}]}',
    "duplicate.json": '{"joints": [{"name": "a", "parent": null, "position": [0, 0, 0]},'
                      ' {"name": "a", "parent": null, "position": [0, 1, 0]}]}',
    "syntax.bvh": "HIERARCHY\nROOT hips\n{\n  OFFSET 0 0\n}\n",
    "unskinned.glb": "mesh",
    "garbage.glb": "glTF not really",
    "skeleton.txt": "hips 0 0 0",
}


@pytest.mark.parametrize("name", sorted(BAD_SKELETONS))
def test_bad_skeleton_files_exit_3_with_one_line(tmp_path, name):
    path = tmp_path / name
    content = BAD_SKELETONS[name]
    if content == "mesh":
        trimesh.creation.box().export(path)
    elif content is not None:
        path.write_text(content)
    out = tmp_path / "out.glb"
    run = run_cli(MANNEQUIN, "--skeleton", path, "-o", out)
    assert run.returncode == 3, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("autorig: error: skeleton") and "Traceback" not in run.stderr
    assert not out.exists() and run.stdout == ""
    with pytest.raises(SkeletonError):
        read_skeleton(path)


@pytest.mark.parametrize("args", [["--template", "quadruped"], ["--strict"], ["--skeleton-scale", "-2"],
                                  ["--skeleton-scale", "big"], ["--up", "z"]])
def test_skeleton_usage_errors_exit_2(tmp_path, args):
    run = run_cli(MANNEQUIN, "--skeleton", MANNEQUIN_JOINTS, "-o", tmp_path / "out.glb", *args)
    assert run.returncode == 2 and "Error" in run.stderr, run.stderr
    assert not (tmp_path / "out.glb").exists()



def test_pinocchio_output_needs_one_root_and_a_bone(tmp_path):
    lone = tmp_path / "lone.json"
    lone.write_text(json.dumps({"joints": [{"name": "root", "parent": None, "position": [0, 1, 0]}]}))
    run = run_cli(MANNEQUIN, "--skeleton", lone, "-f", "pinocchio", "-o", tmp_path / "rig")
    assert run.returncode == 2 and "at least one bone" in run.stderr and "Traceback" not in run.stderr, run.stderr
    assert not (tmp_path / "rig").exists()

# --- rules -----------------------------------------------------------------------------------------------------

def test_loose_parts_and_cold_bones_are_all_weighted():
    """A prop floating beside the hand holding only a leaf joint goes to that joint; a loose part with no joint
    still gets weights; a bone outside the mesh heats nothing; rows sum to 1 everywhere."""
    V, F = load_mesh(MANNEQUIN)
    skeleton = read_skeleton(MANNEQUIN_JOINTS)
    hand = skeleton.positions[skeleton.names.index("left_hand_end")]
    prop = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    prop.apply_translation(hand + [0.25, 0, 0])
    loose = trimesh.creation.icosphere(radius=0.05)
    loose.apply_translation([0.0, 1.9, 0.4])                                # above and in front of the head
    mesh = trimesh.util.concatenate([trimesh.Trimesh(V, F, process=False), prop, loose])
    document = json.loads(MANNEQUIN_JOINTS.read_text())
    document["joints"] += [{"name": "prop", "parent": "left_wrist", "position": (hand + [0.25, 0, 0]).tolist()},
                           {"name": "ground", "parent": None, "position": [0.0, -1.0, 0.0]},
                           {"name": "ground_to_hips", "parent": "ground", "position": [0.0, 0.5, 0.0]}]
    from autorig.exchange.skeleton import skeleton_from_joints
    names = [j["name"] for j in document["joints"]]
    parents = [names.index(j["parent"]) if j["parent"] else -1 for j in document["joints"]]
    custom = skeleton_from_joints(names, parents, [j["position"] for j in document["joints"]])
    rig = autorig.skin((np.asarray(mesh.vertices), np.asarray(mesh.faces)), custom)
    check_weights(rig.weights, len(mesh.vertices))
    assert (rig.weights.sum(axis=1) > 0).all()
    dominant = np.array(rig.names)[np.argmax(rig.weights, axis=1)]
    in_prop = slice(len(V), len(V) + len(prop.vertices))
    assert (dominant[in_prop] == "prop").all()
    assert rig.weights[:, rig.names.index("ground")].max() == 0             # its bone lies below the feet
    assert "ground -> ground_to_hips" in rig.info["cold_bones"]["outside"]


def test_weights_do_not_depend_on_the_units():
    V, F = load_mesh(MANNEQUIN)
    skeleton = read_skeleton(MANNEQUIN_JOINTS)
    metres = autorig.skin((V, F), skeleton)
    skeleton.positions = skeleton.positions * 1000.0
    millimetres = autorig.skin((V * 1000.0, F), skeleton)
    np.testing.assert_allclose(millimetres.weights, metres.weights, atol=1e-6)


def test_tip_rule_by_geometry_not_names():
    """A leaf with body beyond it owns a tip bone; one at the body's end does not, whatever it is called."""
    box = trimesh.creation.box(extents=[0.2, 1.0, 0.2])                     # a bar from y=-0.5 to 0.5
    V, F = np.asarray(box.vertices), np.asarray(box.faces)
    plan = plan_heat(V, F, ["root", "hand"], [[0, -0.45, 0], [0, 0.45, 0]], [-1, 0])
    assert plan.tips == []                                                  # "hand" sits at the bar's end
    plan = plan_heat(V, F, ["root", "leaf_end"], [[0, -0.45, 0], [0, 0.0, 0]], [-1, 0])
    assert plan.tips == ["leaf_end"]                                        # half the bar is beyond it


# --- the artists' rigs -----------------------------------------------------------------------------------------

def score(gt_dir: Path, glb: Path, tmp_path: Path) -> dict:
    """score.py's weight scores of ``glb``, each GT joint mapped to its own template key."""
    meta = json.loads((gt_dir / "joints.json").read_text())
    kind = "biped" if "biped_map" in meta else "quadruped"
    own = {n: k for k, n in meta[kind + "_map"].items() if n is not None}
    mapping = tmp_path / "map.json"
    mapping.write_text(json.dumps(own))
    run = subprocess.run([sys.executable, str(SHARED / "tools" / "score.py"), str(gt_dir), str(glb), "--kind", kind,
                          "--map", str(mapping)], capture_output=True, text=True, check=True)
    return json.loads(run.stdout)["weights"]


@pytest.mark.skipif(not RIGGED.is_dir(), reason="shared data (../shared/data) is not present")
@pytest.mark.parametrize("model, least", [("CesiumMan", 95.6), ("RiggedFigure", 83.9), ("Fox", 90.3)])
def test_artists_skeletons_beat_blender(tmp_path, model, least):
    """At least Blender's automatic weights' top-1 on the same skeleton (the issue's numbers, and for the Fox our
    benchmark's measurement of Blender 3.4, which is higher), with every vertex weighted."""
    gt_dir = RIGGED / model
    out = tmp_path / f"{model}.glb"
    run = run_cli(gt_dir / "mesh.obj", "--skeleton", gt_dir / "joints.json", "-o", out, "-q")
    assert run.returncode == 0, run.stderr
    result = score(gt_dir, out, tmp_path)
    assert result["top1_pct"] >= least, result
    assert result["pred_zero_rows"] == 0
