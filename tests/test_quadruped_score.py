"""The convention-free quadruped score (``benchmarks/quadruped_score.py``) on constructed rigs: limbs as points,
trunk against the rig's hips-spine-chest-neck-head polyline. The strict per-joint comparison uses
``../shared/tools/score.py`` when it is there and is skipped otherwise."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT.parent / "shared" / "tools"
sys.path.insert(0, str(ROOT / "benchmarks"))

from quadruped_score import TRUNK, convention_free, distance_to_polyline  # noqa: E402

HEIGHT = 2.0


def animal() -> dict[str, np.ndarray]:
    """{template key: position [3]} of a stick quadruped: +y up, +z front, trunk along z at y = 1.5."""
    joints = {"hips": (0, 1.5, -1.0), "spine": (0, 1.5, -0.3), "chest": (0, 1.5, 0.4), "neck": (0, 1.6, 1.0),
              "head": (0, 1.9, 1.4), "tail_base": (0, 1.5, -1.2)}
    for side, x in (("left", 0.3), ("right", -0.3)):
        for end, z, top in (("back", -1.0, "hip"), ("front", 0.4, "shoulder")):
            middle, low = ("knee", "ankle") if end == "back" else ("elbow", "wrist")
            joints.update({f"{end}_{side}_{top}": (x, 1.3, z), f"{end}_{side}_{middle}": (x, 0.8, z + 0.1),
                           f"{end}_{side}_{low}": (x, 0.3, z), f"{end}_{side}_paw": (x, 0.0, z + 0.1)})
    return {key: np.array(p, float) for key, p in joints.items()}


def test_a_rig_equal_to_the_truth_scores_zero():
    result = convention_free(animal(), animal(), HEIGHT)
    assert result["limbs_mean"] == result["limbs_worst"] == result["trunk_worst"] == 0.0
    assert set(result["trunk"]) == set(TRUNK)
    assert not set(result["limbs"]) & set(TRUNK) and "head" in result["limbs"]


def test_a_limb_joint_moved_by_d_scores_d_percent_of_the_height():
    rig = animal()
    rig["back_left_knee"] = rig["back_left_knee"] + [0.0, 0.06, -0.08]        # moved by 0.1
    result = convention_free(animal(), rig, HEIGHT)
    assert result["limbs_worst_joint"] == "back_left_knee"
    assert result["limbs_worst"] == pytest.approx(100 * 0.1 / HEIGHT)
    assert result["limbs_mean"] == pytest.approx(100 * 0.1 / HEIGHT / len(result["limbs"]))
    assert result["trunk_worst"] == 0.0


def slid_along_the_trunk(joints: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The artist's hips, spine, chest and neck moved along the rig's trunk line, each to another place on it."""
    out = dict(joints)
    out["hips"] = joints["hips"] + [0.0, 0.0, 0.2]
    out["spine"] = joints["spine"] + [0.0, 0.0, 0.5]
    out["chest"] = (joints["chest"] + joints["neck"]) / 2
    out["neck"] = 0.3 * joints["neck"] + 0.7 * joints["head"]
    return out


def test_trunk_joints_slid_along_the_rig_trunk_line_cost_nothing():
    result = convention_free(slid_along_the_trunk(animal()), animal(), HEIGHT)
    assert result["trunk_worst"] == pytest.approx(0.0, abs=1e-12)
    assert result["limbs_worst"] == 0.0


def test_a_trunk_joint_off_the_line_scores_its_distance_from_it():
    truth = animal()
    truth["spine"] = truth["spine"] + [0.0, -0.12, 0.0]       # below the straight hips-chest segment
    result = convention_free(truth, animal(), HEIGHT)
    assert result["trunk_worst_joint"] == "spine"
    assert result["trunk_worst"] == pytest.approx(100 * 0.12 / HEIGHT)


def test_distance_to_polyline_measures_to_the_segments_not_their_lines():
    line = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    assert distance_to_polyline(np.array([0.5, -0.2, 0]), line) == pytest.approx(0.2)
    assert distance_to_polyline(np.array([-0.3, 0.4, 0]), line) == pytest.approx(0.5)   # past the first end
    assert distance_to_polyline(np.array([2.0, 0.5, 0]), line) == pytest.approx(1.0)
    assert distance_to_polyline(np.array([0.0, 3, 4]), line[:1]) == pytest.approx(5.0)


@pytest.mark.skipif(not (TOOLS / "score.py").is_file(), reason="../shared/tools/score.py is not present")
def test_sliding_along_the_trunk_is_an_error_to_the_strict_score():
    sys.path.insert(0, str(TOOLS))
    import score
    truth = slid_along_the_trunk(animal())
    names = list(truth)
    gt = {"name": "stick", "kind": "quadruped", "joint_names": names, "map": {k: k for k in names},
          "joint_pos": np.array([truth[k] for k in names]), "height": HEIGHT}
    strict = score.joint_errors(gt, animal())
    assert strict["per_key"]["spine"] == pytest.approx(0.5 / HEIGHT)
    assert convention_free(score.gt_template_joints(gt), animal(), HEIGHT)["trunk_worst"] < 1e-9


def test_a_truth_without_trunk_joints_has_no_trunk_score():
    from quadruped_score import line
    truth = {key: p for key, p in animal().items() if key not in TRUNK}
    result = convention_free(truth, animal(), HEIGHT)
    assert result["trunk"] == {} and result["trunk_worst"] is None
    assert "trunk    - (None)" in line(result)
