"""The humanoid template: the biped's body with clavicles and three spine joints, its fingers flag, the rest pose
each rig reports (T, A, arms down), its joints under every engine's names, and a Mixamo motion on it."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

import autorig
from autorig.errors import TemplateError
from autorig.exchange.gltf import read_glb
from autorig.exchange.obj import write_obj
from autorig.learn.humanoid_map import humanoid_map, with_humanoid_map
from autorig.naming import BIPED_JOINTS, HUMANOID_JOINTS, rename_joints, scheme_names, template_names
from autorig.show.pose import joint_map
from autorig.readoff.rest_pose import arm_angle, pose_name
from autorig.samples import mannequin
from autorig.template import load_template, template_from_dict

ROOT = Path(__file__).resolve().parents[1]
EXTRA = {"spine1", "spine2", "left_clavicle", "right_clavicle"}
# The bones Unity's Humanoid avatar cannot do without (HumanTrait.RequiredBone).
UNITY_REQUIRED = {"Hips", "Spine", "Head", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "RightUpperLeg",
                  "RightLowerLeg", "RightFoot", "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightUpperArm",
                  "RightLowerArm", "RightHand"}


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autorig.cli", *map(str, args)], capture_output=True, text=True)


@lru_cache(maxsize=None)
def humanoid_rig(pose: str):
    """(sample, rig) of the adult mannequin in ``pose`` ("t", "a", "down") rigged by the shipped humanoid."""
    sample = mannequin(pose=pose)
    return sample, autorig.rig((sample.vertices, sample.faces), "humanoid")


@pytest.fixture(scope="module")
def mannequin_obj(tmp_path_factory) -> Path:
    sample = humanoid_rig("t")[0]
    path = tmp_path_factory.mktemp("humanoid") / "hero.obj"
    write_obj(sample.vertices, sample.faces, path)
    return path


def test_the_humanoid_is_the_bipeds_body_with_clavicles_and_three_spine_joints():
    humanoid, biped = load_template("humanoid"), load_template("biped")
    assert set(humanoid.names) == (set(biped.names) - {"chest"}) | EXTRA
    parent = {n: humanoid.names[p] if p >= 0 else None for n, p in zip(humanoid.names, humanoid.parents)}
    assert [parent["spine"], parent["spine1"], parent["spine2"], parent["neck"]] == ["hips", "spine", "spine1",
                                                                                      "spine2"]
    for side in ("left", "right"):
        assert parent[f"{side}_clavicle"] == "spine2" and parent[f"{side}_shoulder"] == f"{side}_clavicle"
    assert humanoid.fingers and not biped.fingers
    # The embedding places the biped's reduced skeleton: the new joints are degree-2 joints along its paths.
    h, b = humanoid.reduced(), biped.reduced()
    def bones(template, reduced, rename=lambda n: n):
        return {(rename(template.names[j]), rename(template.names[reduced.joints[p]]) if p >= 0 else None)
                for j, p in zip(reduced.joints, reduced.parents)}
    assert bones(humanoid, h) == bones(biped, b, lambda n: "spine2" if n == "chest" else n)
    # Learned, with the biped's conventions, its clavicles between the spine and the upper arms.
    assert humanoid.learned_from is not None and set(humanoid.conventions) == set(biped.conventions)
    t = dict(zip(humanoid.names, humanoid.positions))
    assert 0 < t["left_clavicle"][0] < t["left_shoulder"][0] and t["left_clavicle"][1] > t["spine2"][1]
    assert t["spine"][1] < t["spine1"][1] < t["spine2"][1] < t["neck"][1]


def test_the_fingers_flag_is_checked_and_carried(tmp_path):
    data = json.loads((ROOT / "templates" / "handset" / "humanoid.json").read_text())
    template = template_from_dict(data)
    assert template.fingers
    again = template_from_dict(template.to_dict())
    assert again.fingers and again.names == template.names
    assert "fingers" not in load_template("biped").to_dict()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**data, "fingers": "yes"}))
    with pytest.raises(TemplateError, match="fingers"):
        load_template(bad)
    mesh = tmp_path / "hero.obj"
    sample = humanoid_rig("t")[0]
    write_obj(sample.vertices, sample.faces, mesh)
    run = run_cli(mesh, "--template", bad, "-o", tmp_path / "hero.glb")
    assert run.returncode != 0 and run.stderr.count("\n") == 1 and "fingers" in run.stderr
    assert not (tmp_path / "hero.glb").exists()


def test_the_humanoid_map_reads_the_spine_and_clavicles_off_the_hierarchy():
    biped_map = {"hips": "Hips", "spine": "Spine", "chest": "Spine2", "neck": "Neck", "left_shoulder": "LeftArm",
                 "right_shoulder": "RightArm"}
    mixamo = {"Hips": None, "Spine": "Hips", "Spine1": "Spine", "Spine2": "Spine1", "Neck": "Spine2",
              "LeftShoulder": "Spine2", "LeftArm": "LeftShoulder", "RightShoulder": "Spine2",
              "RightArm": "RightShoulder"}
    found = humanoid_map(biped_map, mixamo)
    assert "chest" not in found
    assert (found["spine"], found["spine1"], found["spine2"]) == ("Spine", "Spine1", "Spine2")
    assert (found["left_clavicle"], found["right_clavicle"]) == ("LeftShoulder", "RightShoulder")
    # Arms straight off the chest and no joint between spine and chest: nothing to map (the learner fills).
    plain = {"Hips": None, "Spine": "Hips", "Spine2": "Spine", "Neck": "Spine2", "LeftArm": "Spine2",
             "RightArm": "Spine2"}
    found = humanoid_map(biped_map, plain)
    assert found["spine1"] is None and found["left_clavicle"] is None and found["spine2"] == "Spine2"
    # A map the file has itself wins.
    meta = {"biped_map": biped_map, "humanoid_map": {"hips": "Hips"}}
    assert with_humanoid_map(meta, [])["humanoid_map"] == {"hips": "Hips"}


@pytest.mark.parametrize("pose,expected", [("t", "T"), ("a", "A"), ("down", "arms down")])
def test_each_rest_pose_rigs_and_is_reported(pose, expected):
    sample, rig = humanoid_rig(pose)
    assert rig.info["rest_pose"] == expected
    height = float(np.ptp(sample.vertices[:, 1]))
    at = dict(zip(rig.names, rig.joints))
    errors = [np.linalg.norm(at[n] - sample.joints[n]) / height for n in sample.joints
              if n in at and not n.endswith("_end")]
    assert np.mean(errors) < 0.05
    for side, sign in (("left", 1), ("right", -1)):
        # The collarbone runs out from the top of the spine towards the upper arm.
        clavicle, shoulder, spine2 = at[f"{side}_clavicle"], at[f"{side}_shoulder"], at["spine2"]
        assert sign * spine2[0] < sign * clavicle[0] < sign * shoulder[0]
        assert clavicle[1] > spine2[1]


def test_the_json_report_says_the_rest_pose(mannequin_obj, tmp_path):
    out = tmp_path / "hero.json"
    run = run_cli(mannequin_obj, "--template", "humanoid", "-o", out)
    assert run.returncode == 0, run.stderr
    info = json.loads(out.read_text())["info"]
    assert info["rest_pose"] == "T" and abs(info["arm_angle"]) < 20


def test_pose_names_follow_the_arms_angle():
    assert [pose_name(a) for a in (0, 19, 30, 45, 70, 90)] == ["T", "T", "A", "A", "arms down", "arms down"]
    joints = np.array([[0.1, 0.8, 0.0], [0.4, 0.8 - 0.3 * np.tan(np.radians(35)), 0.0]])
    assert arm_angle(np.vstack([joints, joints * [-1, 1, 1]]), ["left_shoulder", "left_wrist", "right_shoulder",
                                                                "right_wrist"]) == pytest.approx(35)
    assert arm_angle(joints, ["hips", "spine"]) is None


@pytest.mark.parametrize("scheme", ["mixamo", "unity", "unreal"])
def test_every_engine_names_the_whole_body_and_back(scheme):
    rig = humanoid_rig("t")[1]
    named = rename_joints(rig, scheme)
    assert len(set(named.names)) == len(named.names) == len(rig.names)
    assert template_names(named.names) == list(rig.names)
    table = scheme_names(scheme)
    assert {table[n] for n in HUMANOID_JOINTS} <= set(named.names)
    # The biped keeps its own names under every scheme, and maps back as the biped.
    biped_names = [table[n] for n in BIPED_JOINTS]
    assert template_names(biped_names) == list(BIPED_JOINTS)


def test_engine_names_are_the_engines_own(mannequin_obj, tmp_path):
    rig = humanoid_rig("t")[1]
    unreal = set(rename_joints(rig, "unreal").names)
    assert {"pelvis", "spine_01", "spine_02", "spine_03", "neck_01", "head", "clavicle_l", "upperarm_l",
            "lowerarm_l", "hand_l", "thigh_l", "calf_l", "foot_l", "ball_l", "clavicle_r", "ball_r"} <= unreal
    unity = set(rename_joints(rig, "unity").names)
    assert UNITY_REQUIRED | {"Chest", "UpperChest", "Neck", "LeftShoulder", "RightShoulder", "LeftToes"} <= unity
    out = tmp_path / "hero.glb"
    run = run_cli(mannequin_obj, "--template", "humanoid", "--names", "mixamo", "-o", out)
    assert run.returncode == 0, run.stderr
    assert ", T (" in run.stdout          # the rest pose found, in the summary line
    names = read_glb(out).names
    assert {"mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2", "mixamorig:LeftShoulder",
            "mixamorig:LeftArm", "mixamorig:RightShoulder", "mixamorig:HeadTop_End"} <= set(names)
    assert all(n.startswith("mixamorig:") for n in names)


def test_engine_names_for_a_quadruped_are_one_line(mannequin_obj):
    run = run_cli(mannequin_obj, "--template", "quadruped", "--names", "unreal")
    assert run.returncode == 3 and run.stderr.count("\n") == 1 and "humanoid" in run.stderr


def test_a_mixamo_motion_maps_the_clavicles_and_spine_of_a_humanoid_rig():
    rig = humanoid_rig("t")[1]
    mixamo = ["mixamorig:" + n for n in ("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head", "LeftShoulder",
                                         "LeftArm", "LeftForeArm", "LeftHand", "RightShoulder", "RightArm")]
    for names in (list(rig.names), rename_joints(rig, "mixamo").names):
        mapping = dict(zip(template_names(list(names)), (joint_map(list(names), mixamo).get(n) for n in names)))
        assert mapping["left_clavicle"] == "mixamorig:LeftShoulder" and mapping["left_shoulder"] == "mixamorig:LeftArm"
        assert (mapping["spine"], mapping["spine1"], mapping["spine2"]) == tuple(
            "mixamorig:" + n for n in ("Spine", "Spine1", "Spine2"))
    # A MotionBuilder-style file calls the upper arm LeftShoulder and the collarbone LeftCollar; without a
    # collarbone, the clavicle stays unmapped rather than taking the arm's joint.
    assert joint_map(list(rig.names), ["Hips", "LeftCollar", "LeftShoulder"])["left_clavicle"] == "LeftCollar"
    mapping = joint_map(list(rig.names), ["Hips", "LeftShoulder", "LeftElbow"])
    assert mapping["left_shoulder"] == "LeftShoulder" and "left_clavicle" not in mapping


@pytest.mark.skipif(shutil.which("blender") is None, reason="blender is not installed (apt-get install blender)")
def test_an_fbx_with_mixamo_names_loads_in_blender_with_the_body_bones(mannequin_obj, tmp_path):
    from test_blender import render_report
    out = tmp_path / "hero.fbx"
    run = run_cli(mannequin_obj, "--template", "humanoid", "--names", "mixamo", "-o", out)
    assert run.returncode == 0, run.stderr
    report = render_report(out, tmp_path / "hero.png")
    assert report["armatures"] == 1
    table = scheme_names("mixamo")
    assert sorted(report["bones"]) == sorted(table[n] for n in HUMANOID_JOINTS)
