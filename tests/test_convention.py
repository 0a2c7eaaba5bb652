"""Conventions: where each studio puts its joints, apart from the shared anatomy (``autorig.embed.convention``,
``autorig.learn.conventions``, ``autorig conventions``, ``autorig MESH --convention``)."""
from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import autorig
from autorig.embed.convention import REFERENCE_BAND, REFERENCE_SWITCH, joint_frames, local_offsets, moved
from autorig.errors import TemplateError
from autorig.learn.conventions import convention_for_source, default_convention, fit_conventions, named_sources, source_of
from autorig.learn.examples import Example
from autorig.samples import mannequin
from autorig.template import load_template, template_from_dict

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autorig.cli", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def biped():
    return load_template("biped")


def _depths(template) -> np.ndarray:
    return np.full(len(template.names), 0.04)


def test_offsets_round_trip_and_mirror_images_share_them(biped):
    joints = biped.positions
    rng = np.random.default_rng(3)
    offsets = rng.normal(0, 0.2, (len(joints), 3))
    for i, j in biped.symmetry:
        offsets[j] = offsets[i]
    offsets[[k for k in range(len(joints)) if biped.is_tip(k)]] = 0
    target = moved(joints, offsets, biped, _depths(biped))
    # The move is undone exactly by the offsets it measures.
    assert np.allclose(local_offsets(joints, target, biped, _depths(biped)), offsets, atol=1e-9)
    # The same offsets move a left joint and its right twin to mirror images of each other.
    for i, j in biped.symmetry:
        assert np.allclose(target[i] * [-1, 1, 1], target[j], atol=1e-9)
    # Tips never move.
    tips = [k for k in range(len(joints)) if biped.is_tip(k)]
    assert np.allclose(target[tips], joints[tips])


def test_frames_follow_the_bone_and_scale_with_the_limb(biped):
    axes, scales = joint_frames(biped.positions, biped, _depths(biped) * 2)
    knee, ankle, hip = (biped.names.index(n) for n in ("left_knee", "left_ankle", "left_hip"))
    along = biped.positions[ankle] - biped.positions[knee]
    assert np.allclose(axes[knee, 0], along / np.linalg.norm(along))
    assert scales[knee, 0] == pytest.approx(np.linalg.norm(along))
    assert scales[hip, 1] == pytest.approx(0.08)
    assert np.allclose(axes[hip] @ axes[hip].T, np.eye(3), atol=1e-9)    # orthonormal


def _foot_turned(biped, along_front: float, rise: float = 1.0) -> np.ndarray:
    """The biped's joints with its left ankle-to-toe bone turned about x through the ankle (its length kept)
    so that the bone's direction has ``along_front`` for a . front, rising (``rise`` 1) or falling (-1)."""
    joints = biped.positions.copy()
    ankle, toe = (biped.names.index(n) for n in ("left_ankle", "left_toe"))
    length = np.linalg.norm(joints[toe] - joints[ankle])
    z = along_front
    joints[toe] = joints[ankle] + length * np.array([0.0, rise * np.sqrt(1 - z * z), z])
    return joints


def test_a_bone_turning_through_the_reference_switch_moves_its_joint_continuously(biped):
    # The ankle's frame takes its second axis from the front below |a . front| = 0.9 and from the up above:
    # for a bone rising forward in the mid-plane's direction the two are opposite, so the hard switch moved
    # the joint by twice its offset along b for a bone turned by a rounding error (a MakeHuman body's toe
    # 1.3 % of its height under 1e-6 noise).
    ankle = biped.names.index("left_ankle")
    offsets = np.zeros((len(biped.names), 3))
    offsets[ankle] = (0.1, 0.3, 0.2)
    depth = _depths(biped)
    for rise in (1.0, -1.0):
        below, above = (moved(j, offsets, biped, depth)[ankle] - j[ankle]
                        for j in (_foot_turned(biped, REFERENCE_SWITCH - 1e-7, rise),
                                  _foot_turned(biped, REFERENCE_SWITCH + 1e-7, rise)))
        assert np.linalg.norm(above - below) < 1e-6
        # ... while the move itself is the offset's size (thickness 0.04): nothing was switched off.
        assert np.linalg.norm(below) > 0.005
    # Far from the band each frame is the one it always was: b the front (or the up) made square to the bone.
    for z, reference in ((REFERENCE_SWITCH - 2 * REFERENCE_BAND, [0, 0, 1.0]), (0.5, [0, 0, 1.0]),
                         (REFERENCE_SWITCH + 2 * REFERENCE_BAND, [0, 1.0, 0]), (0.99, [0, 1.0, 0])):
        joints = _foot_turned(biped, z)
        axes, _ = joint_frames(joints, biped, depth)
        a = axes[ankle, 0]
        b = np.asarray(reference) - (np.asarray(reference) @ a) * a
        assert np.array_equal(axes[ankle, 1], b / np.linalg.norm(b))
        assert np.allclose(axes[ankle] @ axes[ankle].T, np.eye(3), atol=1e-12)
    # Inside the band, the offsets a move measures are still the ones that made it.
    joints = _foot_turned(biped, REFERENCE_SWITCH - REFERENCE_BAND / 2)
    target = moved(joints, offsets, biped, depth)
    assert np.allclose(local_offsets(joints, target, biped, depth), offsets, atol=1e-9)


def test_a_convention_is_its_sources_median_shrunk_toward_the_others(biped):
    J = len(biped.names)
    hip = biped.names.index("left_hip")
    depths = _depths(biped)
    known = np.array([not biped.is_tip(j) for j in range(J)])

    def examples(shift, n):
        offsets = np.zeros((J, 3))
        offsets[hip, 0] = offsets[biped.names.index("right_hip"), 0] = shift
        return [biped.positions] * n, [moved(biped.positions, offsets, biped, depths)] * n

    placed_a, truth_a = examples(-0.3, 8)
    placed_b, truth_b = examples(0.3, 8)
    placed_c, truth_c = examples(0.3, 1)
    sources = ["studio"] * 8 + ["engine_a"] * 8 + ["engine_b"]
    conventions = fit_conventions(placed_a + placed_b + placed_c, placed_a + placed_b + placed_c,
                                  truth_a + truth_b + truth_c, [known] * 17,
                                  [depths] * 17, sources, biped, {"engine": ["engine_a", "engine_b"]}, shrink=2.0)
    assert sorted(conventions) == ["engine", "studio"]
    assert conventions["engine"]["sources"] == ["engine_a", "engine_b"] and conventions["engine"]["examples"] == 9
    prior = (-0.3 + 0.3 + 0.3) / 3
    studio = conventions["studio"]["offsets"][hip][0]
    assert studio == pytest.approx((8 * -0.3 + 2 * prior) / 10)
    # The one-example source is pulled most of the way to the prior; the named one is the mean of its sources.
    one = (1 * 0.3 + 2 * prior) / 3
    assert conventions["engine"]["offsets"][hip][0] == pytest.approx(((8 * 0.3 + 2 * prior) / 10 + one) / 2)
    assert convention_for_source(conventions, "studio") == "studio"
    assert convention_for_source(conventions, "engine_b") == "engine"
    assert named_sources(["a", "b", "c"], {"x": ["a", "b", "zz"]}) == {"c": ["c"], "x": ["a", "b"]}


def test_a_pooled_convention_counts_each_family_of_sources_once(biped):
    """One tool's bodies under two rigs (``makehuman``, ``makehuman-ue``) are one family: with a third studio
    they make a pooled convention half that studio's habit, not a third."""
    J = len(biped.names)
    hip, right = biped.names.index("left_hip"), biped.names.index("right_hip")
    depths = _depths(biped)
    known = np.array([not biped.is_tip(j) for j in range(J)])
    placed, truths, sources = [], [], []
    for source, shift in (("gltf", 0.3), ("mh", -0.3), ("mh-ue", -0.1)):
        offsets = np.zeros((J, 3))
        offsets[hip, 0] = offsets[right, 0] = shift
        placed += [biped.positions] * 8
        truths += [moved(biped.positions, offsets, biped, depths)] * 8
        sources += [source] * 8
    conventions = fit_conventions(placed, placed, truths, [known] * 24, [depths] * 24, sources, biped,
                                  {"engine": ["gltf", "mh", "mh-ue"]}, shrink=0.0)
    assert conventions["engine"]["offsets"][hip][0] == pytest.approx((0.3 + (-0.3 - 0.1) / 2) / 2)
    assert sorted(conventions) == ["engine"] and conventions["engine"]["examples"] == 24


def test_template_file_keeps_its_conventions_and_checks_them(biped):
    J = len(biped.names)
    offsets = np.zeros((J, 3))
    offsets[biped.names.index("left_hip")] = (0.2, -0.1, 0.0)
    template = replace(biped, conventions={"studio": {"offsets": offsets.tolist(), "sources": ["s"], "examples": 3},
                                           "engine": {"offsets": (-offsets).tolist(), "sources": ["e"],
                                                      "examples": 5}},
                       default_convention="engine")
    data = template.to_dict()
    back = template_from_dict(json.loads(json.dumps(data)))
    assert back.default_convention == "engine"
    assert np.allclose(back.conventions["studio"]["offsets"], offsets)
    with pytest.raises(TemplateError, match="offsets"):
        template_from_dict({**data, "conventions": {"studio": {"offsets": [[0, 0, 0]]}}})
    with pytest.raises(TemplateError, match="default_convention"):
        template_from_dict({**data, "default_convention": "nobody"})
    with pytest.raises(TemplateError, match="no convention 'nobody'"):
        autorig.rig(_mannequin_pair(), back, autorig.RigOptions(up="y", front="z", convention="nobody"))


def _mannequin_pair():
    sample = mannequin(pose="t", proportions="adult")
    return sample.vertices, sample.faces


def test_the_shipped_biped_puts_the_hip_joints_by_the_convention_asked():
    """The engines' convention (the default) puts the hip joints at the femoral heads, 0 A.D.'s above the
    pelvis: the same mesh, rigged both ways, has its thigh joints lower in the first."""
    template = load_template("biped")
    assert template.default_convention == "engine" and {"engine", "0ad"} <= set(template.conventions)
    sample = mannequin(pose="t", proportions="adult")
    rigs = {c: autorig.rig((sample.vertices, sample.faces), template,
                           autorig.RigOptions(up="y", front="z", convention=c)) for c in ("engine", "0ad")}
    height = np.ptp(sample.vertices[:, 1])
    hip = rigs["engine"].names.index("left_hip")
    assert rigs["engine"].info["convention"] == "engine"
    assert rigs["0ad"].joints[hip, 1] - rigs["engine"].joints[hip, 1] > 0.01 * height
    # The limb ends the embedding found are the same in both: a convention moves joints, not limbs.
    toe = rigs["engine"].names.index("left_toe_end")
    assert np.allclose(rigs["engine"].joints[toe], rigs["0ad"].joints[toe])
    default = autorig.rig((sample.vertices, sample.faces), template, autorig.RigOptions(up="y", front="z"))
    assert np.allclose(default.joints, rigs["engine"].joints)


def test_cli_lists_conventions_and_refuses_an_unknown_one(tmp_path):
    listed = run_cli("conventions")
    assert listed.returncode == 0
    lines = listed.stdout.splitlines()
    assert any(line.startswith("* engine") for line in lines) and any("0ad" in line for line in lines)
    out = tmp_path / "m.glb"
    refused = run_cli(ROOT / "data" / "mannequin.obj", "--convention", "nobody", "-o", out)
    assert refused.returncode == 3 and not out.exists()
    assert len(refused.stderr.strip().splitlines()) == 1 and "engine" in refused.stderr
    handset = run_cli("conventions", "--template", ROOT / "templates" / "handset" / "biped.json")
    assert handset.returncode == 0 and "no conventions" in handset.stdout


def test_batch_rigs_in_the_convention_asked_and_refuses_an_unknown_one(tmp_path):
    from autorig.exchange.gltf import read_glb
    assets = tmp_path / "assets"
    assets.mkdir()
    (assets / "man.obj").write_bytes((ROOT / "data" / "mannequin.obj").read_bytes())
    refused = run_cli("batch", assets, "-o", tmp_path / "bad", "--convention", "nobody", "-j", "1")
    assert refused.returncode == 3 and "nobody" in refused.stderr and not (tmp_path / "bad" / "man.rigged.glb").exists()
    joints = {}
    for convention in ("engine", "0ad"):
        done = run_cli("batch", assets, "-o", tmp_path / convention, "--convention", convention, "-j", "1",
                       "--front", "z", "--up", "y")
        assert done.returncode == 0, done.stderr
        rig = read_glb(tmp_path / convention / "man.rigged.glb")
        joints[convention] = rig.joints[rig.names.index("left_hip")]
    assert joints["0ad"][1] > joints["engine"][1]


def test_an_example_s_source_and_the_default_convention(tmp_path):
    def example(name, meta):
        return Example(name, np.zeros((3, 3)), np.zeros((1, 3), int), "y", "z", [], np.zeros(0, int),
                       np.zeros((0, 3)), np.zeros((3, 0)), meta=meta)
    assert source_of(example("0ad_boar", {"biped_map": {}}), tmp_path / "train" / "0ad_boar") == "0ad"
    assert source_of(example("x", {"source_group": "makehuman"}), tmp_path / "x") == "makehuman"
    assert source_of(example("CesiumMan", {"biped_map": {}}), tmp_path / "rigged" / "CesiumMan") == "rigged"
    # A studio's rigged files are the studio's, whatever their names.
    assert source_of(example("knight_a", {}), tmp_path / "studio" / "knight_a.glb") == "studio"
    conventions = {"studio": {"examples": 8}, "engine": {"examples": 3}}
    assert default_convention(conventions, None) == "studio"
    assert default_convention(conventions, "engine") == "engine"


def test_a_studio_learning_from_its_own_rigs_gets_its_own_convention(tmp_path):
    """``autorig learn studio/ --learn ...,conventions``: the studio's .glb files are one source, named by their
    folder, and the learned template rigs in it unless told."""
    from autorig.exchange import write_rig
    template = load_template("biped")
    studio = tmp_path / "northwind"
    studio.mkdir()
    for pose, proportions in (("t", "adult"), ("a", "heavy"), ("down", "tall")):
        sample = mannequin(pose=pose, proportions=proportions)
        names = [n for n in template.names if n in sample.joints]
        parent = {n: template.names[p] if p >= 0 else None for n, p in zip(template.names, template.parents)}
        skeleton = tmp_path / f"{pose}.json"
        skeleton.write_text(json.dumps({"joints": [{"name": n, "parent": parent[n],
                                                    "position": [float(v) for v in sample.joints[n]]}
                                                   for n in names]}))
        write_rig(autorig.skin((sample.vertices, sample.faces), skeleton), studio / f"hero_{pose}.glb", "glb")
    out = tmp_path / "northwind.json"
    learned = run_cli("learn", studio, "--learn", "proportions,placement,conventions,confidence", "-o", out, "-q")
    assert learned.returncode == 0, learned.stderr
    assert load_template(out).default_convention == "northwind"
    assert run_cli("conventions", "-t", out).stdout.startswith("* northwind")
