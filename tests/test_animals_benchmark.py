"""The animals benchmark's verdicts (``benchmarks/animals.py``) on constructed rigs: structure right or wrong,
anatomy errors in % of the largest extent, the folds of its cross-validation and its summary."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

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


def test_poses_turn_the_artists_bones_and_skin_the_mesh_with_them():
    """A stick animal (+y up, +z front) with one vertex on each bone's end, each weighted to its bone: walking
    swings the front left leg forward and the back left leg back, the head low lowers the head; the truth moves
    with the skeleton and the vertices with their bones."""
    import animal_poses
    from autorig.learn.examples import Example
    names = ["hips", "chest", "neck", "head", "fl_top", "fl_paw", "bl_top", "bl_paw", "fr_top", "fr_paw",
             "br_top", "br_paw"]
    parents = np.array([-1, 0, 1, 2, 1, 4, 0, 6, 1, 8, 0, 10])
    positions = np.array([(0, 1.5, -1.5), (0, 1.5, 1.0), (0, 1.7, 1.5), (0, 2.0, 2.0), (0.3, 1.3, 1.0),
                          (0.3, 0.0, 1.0), (0.3, 1.3, -1.5), (0.3, 0.0, -1.5), (-0.3, 1.3, 1.0), (-0.3, 0.0, 1.0),
                          (-0.3, 1.3, -1.5), (-0.3, 0.0, -1.5)], float)
    vertices = positions[[5, 7, 3]]                   # a paw's vertex on each left leg and the snout's
    weights = np.zeros((3, len(names)))
    weights[[0, 1, 2], [4, 6, 2]] = 1.0               # each vertex follows the bone above it
    key_of = {"front_left_shoulder": 4, "front_left_paw": 5, "back_left_hip": 6, "back_left_paw": 7,
              "front_right_shoulder": 8, "front_right_paw": 9, "back_right_hip": 10, "back_right_paw": 11,
              "neck": 2, "head": 3}
    example = Example("stick", vertices, np.zeros((0, 3), int), "y", "z", names, parents, positions, weights, key_of)
    walking = animal_poses.posed_example(example, "walk")
    assert walking.positions[5][2] > positions[5][2] + 0.3 and walking.positions[5][1] > 0.0   # front paw forward
    assert walking.positions[7][2] < positions[7][2] - 0.3 and walking.positions[11][2] > positions[11][2] + 0.3
    assert np.allclose(walking.vertices[0], walking.positions[5]) and np.allclose(walking.vertices[1],
                                                                                 walking.positions[7])
    assert np.allclose(example.positions, positions)                                 # the example untouched
    low = animal_poses.posed_example(example, "head low")
    assert low.positions[3][1] < positions[3][1] - 0.3 and np.allclose(low.positions[:3], positions[:3])
    assert np.allclose(low.vertices[2], low.positions[3])
    # a game rig's IK foot, a root of its own, is carried with its leg all the same
    ik = Example("ik", vertices, example.faces, "y", "z", names, np.where(np.arange(len(names)) == 5, -1, parents),
                 positions, weights, key_of)
    assert np.allclose(animal_poses.posed_example(ik, "walk").positions, walking.positions)
    del key_of["neck"], key_of["head"]
    assert animal_poses.posed_example(example, "head low") is None


def test_a_lowered_head_stops_at_the_ground():
    """The stick animal's neck turned down until its snout would pass below its paws (the ground): the head
    low turns it as far as the ground lets it, not through the floor; a long neck high above the ground turns
    the whole ``HEAD_LOW``."""
    import animal_poses
    from autorig.learn.examples import Example
    names = ["hips", "chest", "neck", "head", "fl", "fl_paw", "fr", "fr_paw", "bl", "bl_paw", "br", "br_paw"]
    parents = np.array([-1, 0, 1, 2, 1, 4, 1, 6, 0, 8, 0, 10])
    key_of = {"neck": 2, "head": 3, "front_left_shoulder": 4, "front_left_paw": 5, "front_right_shoulder": 6,
              "front_right_paw": 7, "back_left_hip": 8, "back_left_paw": 9, "back_right_hip": 10,
              "back_right_paw": 11}

    def animal(neck_height: float):
        positions = np.array([(0, 1, -1), (0, 1, 1), (0, neck_height, 1.2), (0, neck_height, 3.2), (0.3, 1, 1),
                              (0.3, 0, 1), (-0.3, 1, 1), (-0.3, 0, 1), (0.3, 1, -1), (0.3, 0, -1), (-0.3, 1, -1),
                              (-0.3, 0, -1)], float)
        vertices = positions[[3, 5, 7, 9, 11]]      # the snout's vertex and the four paws'
        weights = np.zeros((5, len(names)))
        weights[[0, 1, 2, 3, 4], [2, 4, 6, 8, 10]] = 1.0
        return Example("stick", vertices, np.zeros((0, 3), int), "y", "z", names, parents, positions, weights,
                       key_of)
    low = animal_poses.posed_example(animal(1.0), "head low")     # 2 long at 1 high: down 30 deg at the ground
    assert low.vertices[0][1] == pytest.approx(0.0, abs=0.01) and low.positions[3][1] >= -0.005
    high = animal_poses.posed_example(animal(3.0), "head low")    # 3 high: the whole 40 deg, snout in the air
    drop = 2.0 * np.sin(np.radians(animal_poses.HEAD_LOW))
    assert high.positions[3][1] == pytest.approx(3.0 - drop, abs=1e-6)
