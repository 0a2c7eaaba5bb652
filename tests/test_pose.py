"""Retargeting a BVH motion onto a rig, skinning, and the animated glTF (autorig.show.pose, `autorig pose`).

Most tests move the rigged mannequin with a BVH of the mannequin's own skeleton (tests/rig_samples.py), so the
expected motion is known; the CMU walk in ../shared/data is used when it is there.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from click.testing import CliRunner
from rig_samples import CMU_NAMES, mannequin_bvh, mannequin_sample, rigged_mannequin, skeleton_bvh
from scipy.spatial.transform import Rotation
from test_exchange import validate

from autorig.cli import cli
from autorig.errors import InputError
from autorig.exchange.animated_gltf import animated_glb_bytes
from autorig.exchange.bvh import parse_bvh, read_bvh
from autorig.exchange.gltf import read_glb, write_glb
from autorig.input.mesh import load_mesh
from autorig.show.pose import joint_map, read_map, retarget, skin

WALK = Path(__file__).resolve().parents[2] / "shared" / "data" / "motion" / "delfem2_walk.bvh"
LIMBS = [("left_hip", "left_knee"), ("left_knee", "left_ankle"), ("right_hip", "right_knee"),
         ("right_knee", "right_ankle"), ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
         ("right_shoulder", "right_elbow"), ("right_elbow", "right_wrist")]

# Frame 0 rest; 1: left knee bent 60 degrees and the root 0.5 m forward; 2: the left arm lowered 60 degrees,
# the right elbow turned 90 degrees about y, the root down 0.2 m and 0.1 m to the left.
POSES = [{}, {"left_knee": (60, 0, 0)}, {"left_shoulder": (0, 0, -60), "right_elbow": (0, 90, 0)}]
MOVES = [(0, 0, 0), (0, 0, 0.5), (0.1, -0.2, 0)]


@pytest.fixture(scope="module")
def rig():
    return rigged_mannequin()[1]


@pytest.fixture(scope="module")
def motion():
    return parse_bvh(mannequin_bvh(POSES, MOVES), name="mannequin.bvh")


@pytest.fixture(scope="module")
def animation(rig, motion):
    return retarget(rig, motion)


def height(rig) -> float:
    return float(np.ptp(rig.vertices[:, 1]))


def near(rig, joint: str, radius: float = 0.06) -> np.ndarray:
    """[V] bool: vertices within ``radius`` metres of ``joint`` at rest."""
    return np.linalg.norm(rig.vertices - rig.joint(joint), axis=1) < radius


def follow(rig, animation, frame: int, joint: str, points: np.ndarray) -> np.ndarray:
    """Where ``points`` [N, 3] go if they move rigidly with ``joint`` at ``frame``."""
    j = rig.names.index(joint)
    return (points - rig.joints[j]) @ animation.rotations[frame, j].T + animation.positions[frame, j]


def bone(rig, animation, frame: int, parent: str, child: str) -> np.ndarray:
    """The vector [3] from joint ``parent`` to joint ``child`` at ``frame``."""
    return animation.positions[frame, rig.names.index(child)] - animation.positions[frame, rig.names.index(parent)]


def angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


# ---------------------------------------------------------------------------------------------- joint map

def test_cmu_names_map_to_the_biped(rig, motion):
    mapping = joint_map(rig.names, motion.names)
    assert mapping["left_shoulder"] == "LeftArm"  # the upper arm, not CMU's collarbone "LeftShoulder"
    assert mapping["left_knee"] == "LeftLeg" and mapping["hips"] == "Hips" and mapping["chest"] == "Spine1"
    assert "head_end" not in mapping


def test_mixamo_prefixes_and_other_conventions(rig):
    mixamo = ["mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2",
              "mixamorig:LeftShoulder", "mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:LeftHand"]
    mapping = joint_map(rig.names, mixamo)
    assert mapping["hips"] == "mixamorig:Hips"
    assert mapping["chest"] == "mixamorig:Spine2"
    assert mapping["left_shoulder"] == "mixamorig:LeftArm"
    # MotionBuilder-style names: the upper arm is LeftShoulder when there is no LeftArm.
    boxing = ["Hips", "Ab", "Chest", "LeftCollar", "LeftShoulder", "LeftElbow", "LeftWrist", "LeftHip"]
    mapping = joint_map(rig.names, boxing)
    assert mapping["spine"] == "Ab" and mapping["left_shoulder"] == "LeftShoulder"
    assert mapping["left_elbow"] == "LeftElbow" and mapping["left_hip"] == "LeftHip"


def test_overrides(rig, motion, tmp_path):
    path = tmp_path / "map.json"
    path.write_text(json.dumps({"left_wrist": None, "head": "Neck", "spine": "Spine"}))
    mapping = joint_map(rig.names, motion.names, read_map(path))
    assert "left_wrist" not in mapping and mapping["head"] == "Neck"
    with pytest.raises(InputError, match="'tail', which the rig does not have"):
        joint_map(rig.names, motion.names, {"tail": "Hips"})
    with pytest.raises(InputError, match="'Tail', which the motion does not have"):
        joint_map(rig.names, motion.names, {"hips": "Tail"})
    path.write_text("[1, 2]")
    with pytest.raises(InputError, match="expected an object"):
        read_map(path)


def test_an_unmapped_root_is_refused(rig, motion):
    with pytest.raises(InputError, match="root joint 'hips' has no motion joint"):
        retarget(rig, motion, {"left_knee": "LeftLeg"})


# ---------------------------------------------------------------------------------------------- retargeting

def test_rest_frame_keeps_the_rig_in_place(rig, animation):
    posed = skin(rig, animation.rotations[0], animation.positions[0])
    # The rig takes the motion's rest pose, which is the mannequin's true skeleton: close to its own.
    assert np.linalg.norm(posed - rig.vertices, axis=1).max() < 0.05 * height(rig)


def test_knee_bend_moves_the_left_foot_with_the_ankle(rig, animation):
    posed = skin(rig, animation.rotations[1], animation.positions[1])
    root_travel = animation.positions[1, 0] - rig.joints[0]
    assert np.allclose(root_travel, [0, 0, 0.5], atol=0.05)  # centimetres in the file, metres in the rig
    foot = near(rig, "left_ankle")
    assert np.linalg.norm(posed[foot] - follow(rig, animation, 1, "left_ankle", rig.vertices[foot]),
                          axis=1).max() < 0.02 * height(rig)
    assert np.linalg.norm(posed[foot] - rig.vertices[foot] - root_travel, axis=1).min() > 0.15 * height(rig)
    other = near(rig, "right_ankle")
    assert np.linalg.norm(posed[other] - rig.vertices[other] - root_travel, axis=1).max() < 0.03 * height(rig)


def test_bones_point_where_the_motion_bones_point(rig, motion, animation):
    _, motion_positions = motion.world_transforms()
    mapping = animation.mapping
    for frame in range(len(motion.frames)):
        for parent, child in LIMBS:
            ours = bone(rig, animation, frame, parent, child)
            theirs = (motion_positions[frame, motion.names.index(mapping[child])]
                      - motion_positions[frame, motion.names.index(mapping[parent])])
            assert angle(ours, theirs) < 0.5, (frame, parent, child)
    # The left arm was lowered 60 degrees from the T-pose.
    assert angle(bone(rig, animation, 2, "left_shoulder", "left_elbow"), np.array([1.0, 0, 0])) == \
        pytest.approx(60, abs=3)


def test_a_head_leaning_in_the_clips_rest_turns_the_rigs_head_by_the_clips_turn(rig):
    """The clip's head leans 6 degrees forward at rest (its build, not a pose) and nods 8 degrees forward,
    then back: the rig's upright head turns 8 degrees from its own rest each time (copying the world
    direction would make it 14 and 2), while the arms still point where the clip's arms point."""
    from autorig.template import load_template

    template = load_template("biped")
    joints = dict(mannequin_sample().joints)
    head = joints["head"]
    length = np.linalg.norm(joints["head_end"] - head)
    lean = np.radians(6.0)
    joints["head_end"] = head + length * np.array([0.0, np.cos(lean), np.sin(lean)])
    poses = [{}, {"head": (8.0, 0, 0)}, {"head": (-8.0, 0, 0), "left_shoulder": (0, 0, -60)}]
    motion = parse_bvh(skeleton_bvh(list(template.names), CMU_NAMES, template.parents, joints, poses,
                                    [(0, 0, 0)] * 3), name="leaning.bvh")
    animation = retarget(rig, motion)
    d = rig.joint("head_end") - rig.joint("head")
    turned = animation.rotations[:, rig.names.index("head")] @ d
    assert [angle(t, d) for t in turned] == pytest.approx([0.0, 8.0, 8.0], abs=0.05)
    assert turned[1] @ np.array([0, 0, 1.0]) > 0 > turned[2] @ np.array([0, 0, 1.0])     # forward, then back
    assert angle(bone(rig, animation, 2, "left_shoulder", "left_elbow"), np.array([1.0, 0, 0])) == \
        pytest.approx(60, abs=3)


def test_a_head_leaning_in_the_clips_rest_stays_upright_when_the_clip_turns_round(rig):
    """The same leaning head, the whole body turned half round about the vertical: the rig's head turns about
    the vertical with it and stays as upright as at rest (the clip's rest lean mapped onto the rig's rest
    would tip it by twice the lean, 12 degrees, facing back)."""
    from autorig.template import load_template

    template = load_template("biped")
    joints = dict(mannequin_sample().joints)
    head = joints["head"]
    length = np.linalg.norm(joints["head_end"] - head)
    joints["head_end"] = head + length * np.array([0.0, np.cos(np.radians(6.0)), np.sin(np.radians(6.0))])
    motion = parse_bvh(skeleton_bvh(list(template.names), CMU_NAMES, template.parents, joints,
                                    [{}, {"hips": (0, 180.0, 0)}], [(0, 0, 0)] * 2), name="turning.bvh")
    animation = retarget(rig, motion)
    d = rig.joint("head_end") - rig.joint("head")
    half_turn = Rotation.from_euler("y", 180, degrees=True).as_matrix()
    assert angle(animation.rotations[1, rig.names.index("head")] @ d, half_turn @ d) < 0.1


def test_bone_lengths_stay_the_rigs(rig, animation):
    for j, p in rig.bones:
        rest = np.linalg.norm(rig.joints[j] - rig.joints[p])
        posed = np.linalg.norm(animation.positions[:, j] - animation.positions[:, p], axis=1)
        assert np.allclose(posed, rest, atol=1e-9)


def test_the_motion_frame_is_read_off_the_rest_pose(rig):
    """The same motion authored Z-up (up = +z, front = -y) retargets to the same rig motion."""
    text = mannequin_bvh(POSES, MOVES)
    motion = parse_bvh(text)
    z_up = parse_bvh(text)
    to_z_up = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # y -> z, z -> -y
    z_up.offsets = motion.offsets @ to_z_up.T
    z_up.end_sites = {b: o @ to_z_up.T for b, o in motion.end_sites.items()}
    z_up.frames = motion.frames.copy()
    z_up.frames[:, :3] = motion.frames[:, :3] @ to_z_up.T
    # Rotations about the motion's own x, y, z become rotations about x, z, -y: here only the knee (about x)
    # and the left arm (about z -> about -y) and the right elbow (about y -> about z) move.
    for b, channels in enumerate(motion.channels):
        start = sum(len(c) for c in motion.channels[:b]) + (3 if b == 0 else 0)
        z, x, y = motion.frames[:, start:start + 3].T
        z_up.channels[b] = channels[:3] + ["Yrotation", "Xrotation", "Zrotation"] if b == 0 else \
            ["Yrotation", "Xrotation", "Zrotation"]
        z_up.frames[:, start:start + 3] = np.stack([-z, x, y], axis=1)
    a, b = retarget(rig, motion), retarget(rig, z_up)
    assert np.allclose(a.positions, b.positions, atol=1e-6)


def test_dual_quaternion_skinning_keeps_a_twisted_arm_round(rig):
    """Twist the forearm half a turn about itself: linear blend skinning pinches the elbow (the "candy
    wrapper"), dual quaternion skinning keeps its thickness."""
    elbow, wrist = rig.joint("left_elbow"), rig.joint("left_wrist")
    axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    twist = Rotation.from_rotvec(np.pi * 0.98 * axis).as_matrix()
    below = [rig.names.index(n) for n in ("left_elbow", "left_wrist", "left_hand_end")]
    rotations = np.tile(np.eye(3), (len(rig.names), 1, 1))
    rotations[below] = twist
    positions = rig.joints.copy()
    positions[below] = (rig.joints[below] - elbow) @ twist.T + elbow
    blended = (rig.weights[:, rig.names.index("left_shoulder")] > 0.3) & \
              (rig.weights[:, rig.names.index("left_elbow")] > 0.3)
    assert blended.sum() > 10

    def radius(points):
        offset = points - elbow
        return np.linalg.norm(offset - np.outer(offset @ axis, axis), axis=1)

    rest = radius(rig.vertices[blended]).mean()
    assert radius(skin(rig, rotations, positions)[blended]).mean() < 0.5 * rest
    assert radius(skin(rig, rotations, positions, dqs=True)[blended]).mean() == pytest.approx(rest, rel=0.1)
    # Both are the identity at rest.
    still = np.tile(np.eye(3), (len(rig.names), 1, 1))
    for dqs in (False, True):
        assert np.allclose(skin(rig, still, rig.joints, dqs=dqs), rig.vertices, atol=1e-9)


@pytest.mark.skipif(not WALK.exists(), reason="shared data (../shared/data) is not present")
def test_cmu_walk_on_the_mannequin(rig):
    walk = read_bvh(WALK)
    animation = retarget(rig, walk)
    _, walk_positions = walk.world_transforms()
    root = rig.names.index("hips")
    for frame in (60, 150, 240):
        for dqs in (False, True):
            posed = skin(rig, animation.rotations[frame], animation.positions[frame], dqs=dqs)
            travel = animation.positions[frame, root] - rig.joints[root]
            assert np.all(np.isfinite(posed))
            assert np.linalg.norm(posed - rig.vertices - travel, axis=1).max() < height(rig)
            # Walking on the floor: the lowest point stays near the rest pose's soles.
            assert -0.05 * height(rig) < posed[:, 1].min() - rig.vertices[:, 1].min() < 0.1 * height(rig)
        foot = near(rig, "left_ankle")
        assert np.linalg.norm(posed[foot] - follow(rig, animation, frame, "left_ankle", rig.vertices[foot]),
                              axis=1).max() < 0.03 * height(rig)
        for parent, child in LIMBS:
            ours = bone(rig, animation, frame, parent, child)
            theirs = (walk_positions[frame, walk.names.index(animation.mapping[child])]
                      - walk_positions[frame, walk.names.index(animation.mapping[parent])])
            assert angle(ours, theirs) < 1.0
    # 2.9 s of walking forward (+z), some 2.9 m at the mannequin's size.
    assert animation.positions[-1, root, 2] - animation.positions[1, root, 2] > 1.5


# ---------------------------------------------------------------------------------------------- animated glTF

def gltf_skin_at(path: Path, frame: int) -> np.ndarray:
    """The skinned vertices [V, 3] of an animated .glb at keyframe ``frame``, computed the way the glTF spec
    says a viewer must: node TRS with the animation's values, world matrices, joint matrices, 4 weights."""
    doc = pygltflib.GLTF2().load(str(path))
    blob = doc.binary_blob()

    def read(index):
        accessor = doc.accessors[index]
        view = doc.bufferViews[accessor.bufferView]
        dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16, 5125: np.uint32}[accessor.componentType]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[accessor.type]
        return np.frombuffer(blob, dtype=dtype, count=accessor.count * width,
                             offset=view.byteOffset + (accessor.byteOffset or 0)).reshape(accessor.count, width)

    translation = {i: np.asarray(n.translation or [0, 0, 0], dtype=np.float64) for i, n in enumerate(doc.nodes)}
    rotation = {i: np.eye(3) for i in range(len(doc.nodes))}
    for channel in doc.animations[0].channels:
        value = read(doc.animations[0].samplers[channel.sampler].output)[frame].astype(np.float64)
        if channel.target.path == "rotation":
            rotation[channel.target.node] = Rotation.from_quat(value).as_matrix()
        else:
            translation[channel.target.node] = value
    world = {}

    def world_of(i):
        if i not in world:
            local = np.eye(4)
            local[:3, :3], local[:3, 3] = rotation[i], translation[i]
            parent = next((p for p, n in enumerate(doc.nodes) if i in (n.children or [])), None)
            world[i] = local if parent is None else world_of(parent) @ local
        return world[i]

    skin_ = doc.skins[0]
    inverse_bind = read(skin_.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    joint_matrices = np.array([world_of(n) @ inverse_bind[k] for k, n in enumerate(skin_.joints)])
    attributes = doc.meshes[0].primitives[0].attributes
    positions = read(attributes.POSITION).astype(np.float64)
    slots, amounts = read(attributes.JOINTS_0).astype(np.int64), read(attributes.WEIGHTS_0).astype(np.float64)
    homogeneous = np.concatenate([positions, np.ones((len(positions), 1))], axis=1)
    blended = np.einsum("vk,vkab->vab", amounts, joint_matrices[slots])
    return np.einsum("vab,vb->va", blended, homogeneous)[:, :3]


def test_animated_glb_validates_loads_back_and_plays_as_skinned(rig, motion, animation, tmp_path):
    path = tmp_path / "moves.glb"
    path.write_bytes(animated_glb_bytes(rig, animation, name="moves"))
    report = validate(path)
    assert report["errors"] == 0 and report["warnings"] == 0, report["messages"]
    back = read_glb(path)
    assert back.names == rig.names and len(back.vertices) == len(rig.vertices)

    doc = pygltflib.GLTF2().load(str(path))
    (clip,) = doc.animations
    assert clip.name == "moves"
    targets = {(c.target.node, c.target.path) for c in clip.channels}
    assert (rig.names.index("hips"), "translation") in targets
    assert (rig.names.index("left_knee"), "rotation") in targets
    assert (rig.names.index("head_end"), "rotation") not in targets  # never turns: no channel
    times = doc.accessors[clip.samplers[0].input]
    assert times.count == len(motion.frames) and times.max[0] == pytest.approx(motion.times[-1])
    # What a glTF viewer shows is our skinning with the file's 4 strongest weights.
    for frame in range(len(motion.frames)):
        expected = skin(back, animation.rotations[frame], animation.positions[frame])
        assert np.abs(gltf_skin_at(path, frame) - expected).max() < 1e-4


# ---------------------------------------------------------------------------------------------- command line

@pytest.fixture(scope="module")
def files(rig, tmp_path_factory):
    folder = tmp_path_factory.mktemp("pose")
    write_glb(rig, folder / "hero.glb")
    (folder / "moves.bvh").write_text(mannequin_bvh(POSES, MOVES))
    return folder


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="autorig")


def test_cli_writes_an_animated_glb(files, animation):
    result = run("pose", files / "hero.glb", "--motion", files / "moves.bvh")
    assert result.exit_code == 0, result.output
    out = files / "hero.moves.glb"
    assert result.stdout.strip().endswith(f"drives 19 of the rig's 19 joints (its 5 tips aside), 3 frames -> {out}")
    assert validate(out)["errors"] == 0


@pytest.mark.parametrize("dqs", [False, True])
def test_cli_writes_one_posed_frame(files, rig, animation, dqs):
    out = files / f"posed{dqs}.obj"
    result = run("pose", files / "hero.glb", "-m", files / "moves.bvh", "--frame", 1, "-o", out,
                 *(["--dqs"] if dqs else []))
    assert result.exit_code == 0, result.output
    vertices, faces = load_mesh(out)
    back = read_glb(files / "hero.glb")
    assert np.array_equal(faces, rig.faces)
    assert np.abs(vertices - skin(back, animation.rotations[1], animation.positions[1], dqs=dqs)).max() < 1e-4


def test_cli_poses_a_file_in_the_axes_autorig_recorded(files, rig, tmp_path):
    """The same character stored Z-up and facing -y moves the same way, turned, without --up/--front."""
    from dataclasses import replace

    from autorig.input.mesh import frame_rotation
    rotation = frame_rotation("z", "-y").T  # canonical -> input coordinates
    turned = replace(rig, vertices=rig.vertices @ rotation.T, joints=rig.joints @ rotation.T,
                     info={**rig.info, "up": "z", "front": "-y"})
    write_glb(turned, tmp_path / "lying.glb")
    for source, out in ((files / "hero.glb", tmp_path / "upright.obj"), (tmp_path / "lying.glb", tmp_path / "lying.obj")):
        result = run("pose", source, "-m", files / "moves.bvh", "--frame", 1, "-o", out)
        assert result.exit_code == 0, result.output
    upright, lying = load_mesh(tmp_path / "upright.obj")[0], load_mesh(tmp_path / "lying.obj")[0]
    assert np.abs(upright).max() > 0.5 and np.abs(lying - upright @ rotation.T).max() < 1e-4


@pytest.mark.parametrize("args, message", [
    (["--dqs"], "--dqs applies to --frame"),
    (["-o", "out.obj"], "the animated rig is a .glb file"),
    (["--frame", "1", "-o", "out.glb"], "the animated rig is a .glb file, a single frame (--frame N) an .obj"),
    (["--frame", "3"], "3: the motion has 3 frames (0 to 2)"),
])
def test_cli_usage_errors(files, args, message):
    result = run("pose", files / "hero.glb", "-m", files / "moves.bvh", *args)
    assert result.exit_code == 2
    assert message in result.stderr


def test_cli_bad_map_is_one_error_line(files):
    (files / "map.json").write_text('{"tail": "Hips"}')
    result = run("pose", files / "hero.glb", "-m", files / "moves.bvh", "--map", files / "map.json")
    assert result.exit_code == 2
    assert result.stderr.startswith("autorig: error: the joint map names 'tail'")
