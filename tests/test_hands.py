"""Fingers (``autorig.hands``): read off a mesh's hands, weighted per finger, named for Mixamo, posed.

The character is the mannequin with five fingers on each hand (tests/hand_samples.py, 30k faces), whose finger
joints are known; a mitten-handed mannequin must get no fingers and say so.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hand_samples import FINGERS, fingered_mannequin
from rig_samples import skeleton_bvh

import autorig
from autorig.errors import TemplateError
from autorig.exchange.obj import write_obj
from autorig.hands.names import FINGER_NAMES, finger_joint_names
from autorig.hands.stage import read_fingers, skin_with_fingers
from autorig.naming import rename_joints, template_names
from autorig.samples import mannequin
from autorig.template import load_template, template_from_dict

BODY = ("elbow", "wrist", "hand_end")


@pytest.fixture(scope="module")
def hand_mesh():
    return fingered_mannequin()


@pytest.fixture(scope="module")
def fingered_rig(hand_mesh):
    V, F, _ = hand_mesh
    return autorig.rig((V, F), "biped", autorig.RigOptions(fingers=True))


def _arms(joints):
    names = [f"{side}_{j}" for side in ("left", "right") for j in BODY]
    return names, np.array([joints[n] for n in names])


def _hand_length(joints, side):
    return float(np.linalg.norm(joints[f"{side}_middle_end"] - joints[f"{side}_wrist"]))


def test_five_fingers_and_the_thumb_are_read_where_they_were_built(hand_mesh):
    V, F, joints = hand_mesh
    names, positions = _arms(joints)
    fingers = read_fingers(V, F, names, positions)
    assert fingers.status == {"left": "fingers", "right": "fingers"}
    assert sorted(fingers.names) == sorted(finger_joint_names())
    for side in ("left", "right"):
        length = _hand_length(joints, side)
        errors = np.array([np.linalg.norm(p - joints[n]) for n, p in zip(fingers.names, fingers.positions)
                           if n.startswith(side)]) / length
        assert errors.mean() < 0.10 and errors.max() < 0.2, errors
        # Each digit is the one it was built as: its tip nearest its own built tip, the thumb's included.
        tips = {f: fingers.positions[fingers.names.index(f"{side}_{f}_end")] for f in FINGERS}
        for f in FINGERS:
            assert min(FINGERS, key=lambda g: np.linalg.norm(tips[f] - joints[f"{side}_{g}_end"])) == f
        # The palms face the ground in the T-pose.
        assert fingers.palm_normals[side] @ np.array([0.0, -1.0, 0.0]) > 0.8
    parents = dict(zip(fingers.names, fingers.parents))
    assert parents["left_index1"] == "left_wrist" and parents["left_index_end"] == "left_index3"


def test_an_arm_that_ends_short_of_its_hand_is_moved_out_to_it(hand_mesh):
    """Wrist, elbow and hand_end given 0.7 forearms back towards the shoulder (as when the body stages stop an
    arm short): the limb reaches on well past that wrist, so the hand is read from a wrist moved out to it, the
    rig's wrist and hand_end move there, and the fingers, thumb included, are where they were built (from the
    short wrist itself the thumb's base joints lay on the forearm, half a hand off)."""
    V, F, joints = hand_mesh
    names, built = _arms(joints)
    short = built.copy()
    for k in (0, 3):                       # each side's elbow, wrist, hand_end
        short[k:k + 3] -= 0.7 * (built[k + 1] - built[k])
    fingers = read_fingers(V, F, names, short)
    assert fingers.status == {"left": "fingers", "right": "fingers"} and set(fingers.moved) == {"left", "right"}
    moved = fingers.moved_joints(names, short)
    for side in ("left", "right"):
        length = _hand_length(joints, side)
        for joint in ("wrist", "hand_end"):
            k = names.index(f"{side}_{joint}")
            assert np.linalg.norm(moved[k] - built[k]) < 0.05 * length
        assert np.array_equal(moved[names.index(f"{side}_elbow")], short[names.index(f"{side}_elbow")])
        errors = np.array([np.linalg.norm(p - joints[n]) for n, p in zip(fingers.names, fingers.positions)
                           if n.startswith(side)]) / length
        assert errors.mean() < 0.10 and errors.max() < 0.2, errors
        tip = fingers.positions[fingers.names.index(f"{side}_thumb_end")]
        assert min(FINGERS, key=lambda g: np.linalg.norm(tip - joints[f"{side}_{g}_end"])) == "thumb"
    # Given where they were built, nothing moves.
    assert read_fingers(V, F, names, built).moved == {}


def test_fingers_are_read_with_the_arms_hanging_down():
    """Hands by the thighs (palms facing them): the same five digits, the thumb at the front."""
    V, F, joints = fingered_mannequin("down")
    names, positions = _arms(joints)
    fingers = read_fingers(V, F, names, positions)
    assert fingers.status == {"left": "fingers", "right": "fingers"}
    for side in ("left", "right"):
        tip = fingers.positions[fingers.names.index(f"{side}_thumb_end")]
        assert np.linalg.norm(tip - joints[f"{side}_thumb_end"]) < 0.1 * _hand_length(joints, side)


def test_a_mitten_gets_no_fingers_and_says_so():
    sample = mannequin()
    names, positions = _arms(sample.joints)
    fingers = read_fingers(sample.vertices, sample.faces, names, positions)
    assert set(fingers.status.values()) <= {"mitten", "fist"} and len(fingers.status) == 2
    assert fingers.names == [] and fingers.positions.shape == (0, 3)


def test_each_fingers_skin_follows_that_finger(hand_mesh):
    V, F, joints = hand_mesh
    names, positions = _arms(joints)
    parents = [-1, 0, 1, -1, 3, 4]
    fingers = read_fingers(V, F, names, positions)
    W = skin_with_fingers(V, F, positions, parents, names, fingers)
    assert W.shape == (len(V), len(names) + len(fingers.names))
    assert np.all(W >= 0) and np.allclose(W.sum(axis=1), 1.0)
    all_names = names + fingers.names
    top = W.argmax(axis=1)
    for side in ("left", "right"):
        for f in FINGERS:
            # The skin around each finger's last two phalanges (2 -> 3 -> tip, as it was built).
            d = np.full(len(V), np.inf)
            for a, b in ((joints[f"{side}_{f}2"], joints[f"{side}_{f}3"]),
                         (joints[f"{side}_{f}3"], joints[f"{side}_{f}_end"])):
                t = np.clip((V - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
                d = np.minimum(d, np.linalg.norm(V - (a + t[:, None] * (b - a)), axis=1))
            own = d < 0.012
            assert own.sum() >= 5
            owner = [all_names[j] for j in top[own]]
            on_finger = np.mean([n.startswith(f"{side}_{f}") for n in owner])
            assert on_finger > 0.9, (side, f, on_finger)


def test_the_pipeline_adds_fingers_after_the_body_with_weights(fingered_rig, hand_mesh):
    rig = fingered_rig
    _, _, joints = hand_mesh
    assert rig.info["hands"] == {"left": "fingers", "right": "fingers"}
    assert "hands" in rig.timings
    template = load_template("biped")
    assert rig.names[:len(template.names)] == list(template.names)
    assert set(finger_joint_names()) <= set(rig.names)
    assert len(set(rig.names)) == len(rig.names)
    assert all(p < j for j, p in enumerate(rig.parents))
    assert rig.weights.shape == (len(rig.vertices), len(rig.names))
    assert np.allclose(rig.weights.sum(axis=1), 1.0)
    ends = [rig.names.index(n) for n in rig.names if n.endswith("_end")]
    assert np.all(rig.weights[:, ends] == 0)
    index = rig.names.index("left_index2")
    # End to end (the biped's own wrists): the index finger's middle joint near where it was built.
    assert np.linalg.norm(rig.joints[index] - joints["left_index2"]) < 0.2 * _hand_length(joints, "left")


def test_the_biped_reads_no_hands_unless_asked():
    sample = mannequin()
    rig = autorig.rig((sample.vertices, sample.faces), "biped")
    assert "hands" not in rig.info and "hands" not in rig.timings
    assert not load_template("biped").fingers


def test_a_template_opts_in_with_fingers_true():
    data = load_template("biped").to_dict()
    assert "fingers" not in data
    assert template_from_dict({**data, "fingers": True}).fingers
    assert template_from_dict({**data, "fingers": True}).to_dict()["fingers"] is True
    with pytest.raises(TemplateError, match="fingers"):
        template_from_dict({**data, "fingers": "yes"})


def test_mixamo_names_every_finger_once(fingered_rig):
    named = rename_joints(fingered_rig, "mixamo")
    assert len(set(named.names)) == len(named.names)
    for side in ("Left", "Right"):
        for f in ("Thumb", "Index", "Middle", "Ring", "Pinky"):
            for k in (1, 2, 3, 4):
                assert f"mixamorig:{side}Hand{f}{k}" in named.names
        assert f"mixamorig:{side}Hand_End" in named.names and f"mixamorig:{side}Hand" in named.names
    assert template_names(named.names) == fingered_rig.names
    # The engines' tables for the humanoid's schemes.
    assert FINGER_NAMES["unreal"]["left_index1"] == "index_01_l"
    assert FINGER_NAMES["unreal"]["right_thumb3"] == "thumb_03_r"
    assert FINGER_NAMES["unity"]["left_thumb1"] == "LeftThumbProximal"
    assert FINGER_NAMES["unity"]["right_pinky2"] == "RightLittleIntermediate"     # HumanBodyBones' name
    assert all(len(set(table.values())) == 40 for table in FINGER_NAMES.values())


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "autorig.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


def test_the_command_line_says_which_hands_got_fingers(hand_mesh, tmp_path):
    V, F, _ = hand_mesh
    mesh = tmp_path / "hero.obj"
    write_obj(V, F, mesh)
    done = _cli(mesh, "--fingers", "--names", "mixamo", "-o", tmp_path / "hero.json", "-v")
    assert done.returncode == 0, done.stderr
    assert "hands: left fingers, right fingers" in done.stdout
    assert "hands" in done.stderr                                          # -v: the stage's time
    document = json.loads((tmp_path / "hero.json").read_text())
    assert document["info"]["hands"] == {"left": "fingers", "right": "fingers"}
    names = [j["name"] for j in document["joints"]]
    assert "mixamorig:LeftHandIndex1" in names and "mixamorig:RightHandThumb4" in names
    sample = mannequin()
    mitten = tmp_path / "mitten.obj"
    write_obj(sample.vertices, sample.faces, mitten)
    done = _cli(mitten, "--fingers", "-o", tmp_path / "mitten.glb")
    assert done.returncode == 0, done.stderr
    assert "hands: left mitten, right mitten" in done.stdout or "fist" in done.stdout
    for wrong in (("--template", "auto"), ("--skeleton", mesh)):
        done = _cli(mitten, "--fingers", *wrong, "-o", tmp_path / "wrong.glb")
        assert done.returncode == 2 and "--fingers" in done.stderr and "Traceback" not in done.stderr
        assert not (tmp_path / "wrong.glb").exists()


def test_a_mixamo_motion_with_finger_curves_moves_the_fingers(fingered_rig, tmp_path):
    """autorig pose with a Mixamo-named BVH: bending LeftHandIndex1 and 2 moves the index finger's skin and
    not the middle finger's."""
    from autorig.exchange import write_rig
    from autorig.input.mesh import load_mesh

    rig_path = tmp_path / "hero.glb"
    write_rig(rename_joints(fingered_rig, "mixamo"), rig_path, "glb")
    import pygltflib
    assert pygltflib.GLTF2().load(str(rig_path)).scenes[0].extras["autorig_hands"] == fingered_rig.info["hands"]
    motion = tmp_path / "curl.bvh"
    # The rig's own skeleton under Mixamo's names: rest, then the index finger's first two joints bent.
    named = rename_joints(fingered_rig, "mixamo")
    bvh_names = {n: m.split(":")[-1] for n, m in zip(fingered_rig.names, named.names)}
    at = dict(zip(fingered_rig.names, fingered_rig.joints))
    bend = {"left_index1": (60.0, 0.0, 0.0), "left_index2": (60.0, 0.0, 0.0)}
    motion.write_text(skeleton_bvh(fingered_rig.names, bvh_names, fingered_rig.parents, at, [{}, bend],
                                   [(0, 0, 0)] * 2))
    for frame in (0, 1):
        done = _cli("pose", rig_path, "-m", motion, "--frame", frame, "-o", tmp_path / f"f{frame}.obj")
        assert done.returncode == 0, done.stderr
    rest, _ = load_mesh(tmp_path / "f0.obj")
    bent, _ = load_mesh(tmp_path / "f1.obj")
    moved = np.linalg.norm(bent - rest, axis=1)
    top = fingered_rig.weights.argmax(axis=1)
    on = lambda prefix: np.isin(top, [j for j, n in enumerate(fingered_rig.names) if n.startswith(prefix)])  # noqa: E731
    length = _hand_length({n: fingered_rig.joints[j] for j, n in enumerate(fingered_rig.names)}, "left")
    assert np.median(moved[on("left_index")]) > 0.04 * length
    # The neighbour's skin by the web shares some weight with the index finger; the rest of it stays put.
    assert np.median(moved[on("left_middle") | on("left_ring")]) < 0.002 * length
    assert moved[on("right_")].max() < 1e-6
    # The animated rig autorig pose writes plays in Blender, the finger with it (one BVH frame per Blender
    # frame): at frame 1 the index finger's skin has moved, and no part of the body as far as a hand's length.
    from test_blender import BLENDER, blender_report
    if BLENDER is None:
        return
    done = _cli("pose", rig_path, "-m", motion, "-o", tmp_path / "curl.glb")
    assert done.returncode == 0, done.stderr
    report = blender_report(tmp_path / "curl.glb", "mixamorig:LeftHandIndex2", frame=1)
    assert report["armatures"] == 1
    assert 0.04 * length < report["moved_at_frame"] < 0.5 * length


def test_blender_loads_the_fbx_with_mixamos_finger_bones_and_they_move_the_fingers(fingered_rig, tmp_path):
    from test_blender import BLENDER, blender_report, render_report

    if BLENDER is None:
        pytest.skip("blender is not installed (apt-get install blender)")
    from autorig.exchange import write_rig

    named = rename_joints(fingered_rig, "mixamo")
    write_rig(named, tmp_path / "hero.fbx", "fbx")
    report = render_report(tmp_path / "hero.fbx", tmp_path / "hero.png")
    assert report["armatures"] == 1
    assert set(FINGER_NAMES["mixamo"].values()) <= set(report["bones"])
    assert sorted(report["bones"]) == sorted(named.names)
    write_rig(named, tmp_path / "hero.glb", "glb")
    report = blender_report(tmp_path / "hero.glb", "mixamorig:LeftHandIndex2")
    assert report["moved_follow"] > 0.005       # the index finger's skin follows its bone in Blender
    assert report["moved_other"] < 1e-5


def test_batch_rigs_again_when_fingers_are_asked_for(tmp_path):
    from autorig.batch.plan import plan_assets
    from autorig.pipeline import RigOptions

    sample = mannequin()
    (tmp_path / "in").mkdir()
    write_obj(sample.vertices, sample.faces, tmp_path / "in" / "hero.obj")
    keys = [plan_assets(tmp_path / "in", tmp_path / "out", "biped", RigOptions(fingers=f), "glb", ("obj",))[0]
            for f in (False, True, True)]
    assert keys[0].key != keys[1].key == keys[2].key
    assert keys[1].options.fingers


def test_the_batch_report_says_which_hands_got_fingers(tmp_path):
    sample = mannequin()
    (tmp_path / "in").mkdir()
    write_obj(sample.vertices, sample.faces, tmp_path / "in" / "hero.obj")
    for run in (1, 2):     # the second run keeps the rig, and still says so
        done = _cli("batch", tmp_path / "in", "-o", tmp_path / "out", "--fingers", "-j", "1",
                    "--report", tmp_path / f"report{run}.json")
        assert done.returncode == 0, done.stderr
        (asset,) = json.loads((tmp_path / f"report{run}.json").read_text())["assets"]
        assert asset["status"] == ("ok" if run == 1 else "skipped")
        assert set(asset["hands"]) == {"left", "right"} and set(asset["hands"].values()) <= {"mitten", "fist"}


def test_the_humanoid_with_fingers_loads_in_blender_with_all_of_mixamos_52_bones(hand_mesh, tmp_path):
    from test_blender import BLENDER, render_report

    if BLENDER is None:
        pytest.skip("blender is not installed (apt-get install blender)")
    from autorig.exchange import write_rig
    from autorig.naming import HUMANOID_JOINTS, scheme_names

    V, F, _ = hand_mesh
    rig = autorig.rig((V, F), "humanoid")       # the humanoid reads fingers without being asked
    assert rig.info["hands"] == {"left": "fingers", "right": "fingers"}
    named = rename_joints(rig, "mixamo")
    table = scheme_names("mixamo")
    mixamo_52 = {table[n] for n in (*HUMANOID_JOINTS, *finger_joint_names()) if not n.endswith("_end")}
    assert len(mixamo_52) == 52 and "mixamorig:LeftShoulder" in mixamo_52 and "mixamorig:Spine2" in mixamo_52
    write_rig(named, tmp_path / "hero.fbx", "fbx")
    report = render_report(tmp_path / "hero.fbx", tmp_path / "hero.png")
    assert report["armatures"] == 1
    assert mixamo_52 <= set(report["bones"])
