"""Template maps read off a skeleton's geometry (``data/maps/derive.py``) and the loader that reads a rigged
glTF file with such a map as a learning example (``autorig.learn.examples.read_mapped_gltf``). The committed
maps are checked against ``../shared/data/more`` when it is there."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
MORE = ROOT.parent / "shared" / "data" / "more"
sys.path.insert(0, str(ROOT / "data" / "maps"))

import derive  # noqa: E402
from autorig.errors import InputError  # noqa: E402
from autorig.learn.examples import Example, read_examples, read_mapped_gltf  # noqa: E402
from autorig.template import load_template  # noqa: E402


def skeleton(joints: list[tuple[str, str | None, tuple]], head: str) -> derive.Skeleton:
    """A skeleton whose every joint has one vertex of skin at its own place (the head three, the most of any),
    plus a floor vertex at y = 0."""
    names = [n for n, _, _ in joints]
    parents = [names.index(p) if p else -1 for _, p, _ in joints]
    P = np.array([p for _, _, p in joints], float)
    h = names.index(head)
    V = np.vstack([P, P[[h, h]], [[0.0, 0.0, 0.0]]])
    W = np.vstack([np.eye(len(P)), np.eye(len(P))[[h, h, 0]]])
    return derive.Skeleton(names, parents, P, W, V)


def animal(left_named: str) -> derive.Skeleton:
    """A stick animal (+y up, +z front, +x its left) whose bones on +x are named ``_<left_named>``."""
    other = "r" if left_named == "l" else "l"
    joints = [("pelvis", None, (0, 2.0, -2.0)), ("back", "pelvis", (0, 2.1, 0.0)), ("front", "back", (0, 2.1, 2.0)),
              ("skull", "front", (0, 2.8, 3.0)), ("tail", "pelvis", (0, 2.2, -3.0))]
    for tag, x in ((left_named, 1.0), (other, -1.0)):
        joints += [(f"thigh_{tag}", "pelvis", (x, 1.6, -2.0)), (f"shin_{tag}", f"thigh_{tag}", (x, 1.0, -1.8)),
                   (f"heel_{tag}", f"shin_{tag}", (x, 0.55, -2.2)), (f"toe_{tag}", f"heel_{tag}", (x, 0.05, -2.0)),
                   (f"arm_{tag}", "front", (x, 1.6, 2.0)), (f"fore_{tag}", f"arm_{tag}", (x, 0.9, 2.0)),
                   (f"hand_{tag}", f"fore_{tag}", (x, 0.3, 2.0))]
    return skeleton(joints, "skull")


@pytest.mark.parametrize("left_named", ["l", "r"])
def test_an_animals_legs_are_named_by_where_they_lie_not_by_their_names(left_named):
    other = "r" if left_named == "l" else "l"
    mapping = derive.quadruped_map(animal(left_named))
    assert mapping["back_left_hip"] == f"thigh_{left_named}" and mapping["back_right_hip"] == f"thigh_{other}"
    assert mapping["back_left_knee"] == f"shin_{left_named}"
    assert mapping["back_left_ankle"] == f"heel_{left_named}"
    assert mapping["back_left_paw"] == f"toe_{left_named}"
    # the hand 0.3 above the floor of a 1.6 leg is the wrist (the template's wrist share 0.15, paw 0.03)
    assert mapping["front_left_shoulder"] == f"arm_{left_named}" and mapping["front_left_elbow"] == f"fore_{left_named}"
    assert mapping["front_left_wrist"] == f"hand_{left_named}" and mapping["front_left_paw"] is None
    assert (mapping["hips"], mapping["head"], mapping["tail_base"]) == ("pelvis", "skull", "tail")
    assert mapping["chest"] == "front" and mapping["spine"] == "back"


def test_a_bipeds_wrist_is_where_its_hand_branches_into_fingers():
    joints = [("root", None, (0, 1.0, 0)), ("belly", "root", (0, 1.2, 0)), ("ribs", "belly", (0, 1.45, 0)),
              ("neck", "ribs", (0, 1.6, 0)), ("head", "neck", (0, 1.7, 0))]
    for tag, x in (("a", 1.0), ("b", -1.0)):
        joints += [(f"up_{tag}", "ribs", (0.2 * x, 1.5, 0)), (f"low_{tag}", f"up_{tag}", (0.45 * x, 1.5, 0)),
                   (f"hand_{tag}", f"low_{tag}", (0.7 * x, 1.5, 0)), (f"f1_{tag}", f"hand_{tag}", (0.8 * x, 1.5, 0.02)),
                   (f"f2_{tag}", f"hand_{tag}", (0.82 * x, 1.5, -0.02)),
                   (f"thigh_{tag}", "root", (0.1 * x, 0.95, 0)), (f"shin_{tag}", f"thigh_{tag}", (0.1 * x, 0.5, 0)),
                   (f"foot_{tag}", f"shin_{tag}", (0.1 * x, 0.08, 0)), (f"ball_{tag}", f"foot_{tag}", (0.1 * x, 0.02, 0.1)),
                   (f"tip_{tag}", f"ball_{tag}", (0.1 * x, 0.01, 0.2))]
    mapping = derive.biped_map(skeleton(joints, "head"))
    assert mapping["left_wrist"] == "hand_a" and mapping["right_wrist"] == "hand_b"
    assert (mapping["left_shoulder"], mapping["left_elbow"]) == ("up_a", "low_a")
    assert (mapping["left_hip"], mapping["left_knee"], mapping["left_ankle"]) == ("thigh_a", "shin_a", "foot_a")
    assert mapping["left_toe"] == "ball_a"
    assert (mapping["hips"], mapping["chest"], mapping["neck"], mapping["head"]) == ("root", "ribs", "neck", "head")


def test_a_map_file_that_is_not_json_is_one_clear_error(tmp_path):
    bad = tmp_path / "map.json"
    bad.write_text("[1, 2")
    base = load_template(ROOT / "templates" / "handset" / "quadruped.json")
    with pytest.raises(InputError, match="not a template map"):
        read_mapped_gltf(tmp_path / "missing.glb", bad, base)


@pytest.mark.skipif(not MORE.is_dir(), reason="needs ../shared/data/more")
def test_the_committed_maps_are_what_the_geometry_gives():
    assert derive.main(["--more", str(MORE), "--check"]) == 0


@pytest.mark.skipif(not MORE.is_dir(), reason="needs ../shared/data/more")
def test_the_wipf_read_with_its_map_has_its_left_legs_on_its_left():
    base = load_template(ROOT / "templates" / "handset" / "quadruped.json")
    wipf = read_mapped_gltf(MORE / "openclonk_wipf" / "model.glb", ROOT / "data" / "maps" / "openclonk_wipf.json",
                            base)
    assert wipf.source == "openclonk" and (wipf.up, wipf.front) == ("y", "z")
    assert wipf.names[wipf.key_of["front_left_shoulder"]] == "upperarm_r"    # its "_r" bones are on its left
    canonical = wipf.canonical_joints()
    for key in ("front_left_shoulder", "front_left_wrist", "back_left_paw"):
        assert canonical[wipf.key_of[key], 0] > 0.05
        assert canonical[wipf.key_of[key.replace("left", "right")], 0] < -0.05
    assert canonical[wipf.key_of["head"], 2] > canonical[wipf.key_of["tail_base"], 2]
    # read_examples takes such an example as it is, beside corpus folders
    examples = read_examples([wipf, wipf])
    assert all(isinstance(e, Example) and e is wipf for e in examples)
    assert json.loads((ROOT / "data" / "maps" / "openclonk_wipf.json").read_text())["source_group"] == "openclonk"


def test_a_hip_joint_level_with_the_back_is_still_the_legs_top_and_a_joint_too_many_stays_unnamed():
    joints = [("pelvis", None, (0, 2.0, -2.0)), ("back", "pelvis", (0, 2.1, 0.0)), ("front", "back", (0, 2.1, 2.0)),
              ("skull", "front", (0, 2.8, 3.0)), ("tail", "pelvis", (0, 2.2, -3.0))]
    for tag, x in (("L", 1.0), ("R", -1.0)):
        joints += [(f"haunch.{tag}", "pelvis", (x, 2.3, -2.0)), (f"thigh.{tag}", f"haunch.{tag}", (x, 1.6, -2.0)),
                   (f"shin.{tag}", f"thigh.{tag}", (x, 1.0, -1.8)), (f"heel.{tag}", f"shin.{tag}", (x, 0.55, -2.2)),
                   (f"toe.{tag}", f"heel.{tag}", (x, 0.05, -2.0)),
                   (f"arm.{tag}", "front", (x, 1.6, 2.0)), (f"fore.{tag}", f"arm.{tag}", (x, 0.9, 2.0)),
                   (f"hand.{tag}", f"fore.{tag}", (x, 0.05, 2.0))]
    mapping = derive.quadruped_map(skeleton(joints, "skull"))
    # shares of the leg's height: thigh 0.70, shin 0.43, heel 0.24, toe 0.02 against knee 0.63, ankle 0.33, paw 0.03
    assert [mapping[f"back_left_{j}"] for j in ("hip", "knee", "ankle", "paw")] == ["haunch.L", "thigh.L", "heel.L",
                                                                                  "toe.L"]
    assert "shin.L" not in mapping.values()
    assert (mapping["front_left_elbow"], mapping["front_left_wrist"], mapping["front_left_paw"]) == ("fore.L", None,
                                                                                                    "hand.L")
