"""The animals benchmark's verdicts (``benchmarks/animals.py``) on constructed rigs: structure right or wrong,
anatomy errors in % of the largest extent, the folds of its cross-validation and its summary."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import animals  # noqa: E402

EXTENT = 4.0


def stick() -> dict[str, np.ndarray]:
    """{template key: position} of a stick animal 4 long (+y up, +z front)."""
    joints = {"hips": (0, 1.5, -1.5), "chest": (0, 1.5, 1.0), "head": (0, 2.0, 2.0)}
    for side, x in (("left", 0.3), ("right", -0.3)):
        for end, z in (("back", -1.5), ("front", 1.0)):
            a, b, c = ("hip", "knee", "ankle") if end == "back" else ("shoulder", "elbow", "wrist")
            joints.update({f"{end}_{side}_{a}": (x, 1.3, z), f"{end}_{side}_{b}": (x, 0.8, z + 0.1),
                           f"{end}_{side}_{c}": (x, 0.3, z), f"{end}_{side}_paw": (x, 0.0, z + 0.1)})
    return {k: np.array(v, float) for k, v in joints.items()}


def test_the_artists_own_joints_score_right_and_zero():
    result = animals.score(stick(), stick(), EXTENT)
    assert result["structure"] and result["anatomy_mean"] == 0.0 and result["anatomy_worst"] == 0.0
    assert set(result["ends"]) == {"front_left", "front_right", "back_left", "back_right", "head"}
    assert "hips" not in result["anatomy"] and "front_left_shoulder" not in result["anatomy"]


def test_front_legs_in_the_hind_legs_are_a_wrong_structure():
    rig = stick()
    for side in ("left", "right"):
        for j in ("elbow", "wrist", "paw"):
            rig[f"front_{side}_{j}"] = stick()[f"back_{side}_{ {'elbow': 'knee', 'wrist': 'ankle'}.get(j, j)}"]
    result = animals.score(rig, stick(), EXTENT)
    assert not result["structure"]
    assert result["ends"]["front_left"]["nearest"] == "back_left" and not result["ends"]["front_left"]["right"]
    assert result["ends"]["back_left"]["right"] and result["ends"]["head"]["right"]
    assert result["anatomy_worst"] == 100 * 2.5 / EXTENT


def test_a_head_nearest_its_own_joint_but_too_far_is_wrong():
    rig = stick()
    rig["head"] = rig["head"] + [0, 0.7, 0]      # 17.5 % of the extent above it, still nearest its own
    result = animals.score(rig, stick(), EXTENT)
    assert result["ends"]["head"]["nearest"] == "head" and not result["ends"]["head"]["right"]
    assert not result["structure"] and result["worst_joint"] == "head"
    rig["head"] = stick()["head"] + [0, 0.5, 0]   # 12.5 %: right
    assert animals.score(rig, stick(), EXTENT)["structure"]


def test_a_leg_without_an_artists_paw_ends_at_its_lowest_joint():
    truth = stick()
    del truth["front_left_paw"], truth["front_left_wrist"]
    assert animals.end_keys(truth)["front_left"] == "front_left_elbow"
    rig = stick()
    rig["front_left_elbow"] = stick()["front_right_paw"]
    assert animals.score(rig, truth, EXTENT)["ends"]["front_left"]["nearest"] == "front_right"
    missing = dict(stick())
    del missing["head"]
    assert not animals.score(missing, stick(), EXTENT)["structure"]


def test_folds_never_split_a_species_and_hold_out_whole_sources():
    zoo = [animals.Animal(f"{src}_{sp}_{i}", src, sp, None) for src, sp, i in
           [("0ad", "fox", 0), ("rigged", "fox", 1), ("0ad", "bovidae", 2), ("0ad", "bovidae", 3),
            ("openclonk", "wipf", 4), ("openclonk", "mooq", 5)]]
    for label, held, trained in animals.folds_of(zoo, "species", 3):
        assert not {a.species for a in held} & {a.species for a in trained}
        assert len(held) + len(trained) == len(zoo)
    by_source = animals.folds_of(zoo, "source", 3)
    assert [label for label, _, _ in by_source] == ["source 0ad", "source openclonk", "source rigged"]
    for label, held, trained in by_source:
        assert {a.source for a in held} == {label.split()[1]} and label.split()[1] not in {a.source for a in trained}


def test_the_summary_counts_right_structures_and_confident_wrong_ones():
    right = animals.score(stick(), stick(), EXTENT)
    wrong = dict(animals.score({**stick(), "head": stick()["hips"]}, stick(), EXTENT))
    rows = [{"template": "quadruped", "cv": "species", "axes": "given", "result": {**r, "confidence": c}}
            for r, c in ((right, 0.9), (wrong, 0.7), (wrong, 0.2))]
    rows.append({"template": "quadruped", "cv": "species", "axes": "given",
                 "result": {"error": "failed", "structure": False, "confidence": None}})
    line = animals.summary(rows)[1].split()
    assert line[:4] == ["quadruped", "species", "given", "1/4"]
    assert "1/3" in line and line[-1] == "1"
