"""The head/tail cues (``autorig.embed.ends``, ``orient.crest_cue``) and detection on generated animals that the
outline's cue reads the wrong way round: a cartoon (a big head straight over the front legs and a long raised tail),
a fox (a long tail held out straight) and a dachshund (a thick tail) (``benchmarks/quadruped_axes.py``'s generator,
each animal with its proportions written out here, none of its seeded family)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import autorig
from autorig.embed.ends import end_bulk_cue
from autorig.input.mesh import prepare
from autorig.embed.orient import head_tail_cue
from autorig.pipeline import discretize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from quadruped_axes import build  # noqa: E402

CARTOON = dict(girth=0.35, legs=0.2, neck=0.05, neck_rise=80.0, head=0.45, snout=0.1, ears="round", tail="raised",
               tail_length=1.2, head_back=0.3, elbow_back=0.1, wrist_forward=0.05, knee_forward=0.15,
               hock_back=0.2, chest=1.1, leg_thickness=0.35)


@pytest.fixture(scope="module")
def cartoon():
    vertices, faces, head, rump = build(CARTOON, resolution=56)
    return vertices, faces, head


def _cues(vertices, faces, up="y", front="z"):
    """(outline cue, bulk cue) of a mesh in the frame (up, front)."""
    prepared = prepare(vertices, faces, up, front)
    _, graph = discretize(prepared)
    return head_tail_cue(prepared.work_vertices), end_bulk_cue(graph, prepared.work_vertices)


def test_the_bulk_cue_finds_the_cartoon_head_the_outline_misses(cartoon):
    vertices, faces, _ = cartoon
    outline, bulk = _cues(vertices, faces)
    assert outline < 0          # the raised tail reaches farther and ends higher than the head
    assert bulk > 0.2


def test_the_bulk_cue_turns_with_the_shape(cartoon):
    vertices, faces, _ = cartoon
    bulk = _cues(vertices, faces)[1]
    # Not to the bit: the medial samples on the octree's centre planes are read from the planes' lower sides
    # (discretize.medial._off_the_centre_planes), which a reversed front mirrors (0.07 % here).
    assert _cues(vertices, faces, "y", "-z")[1] == pytest.approx(-bulk, rel=0.01)
    # The same shape in a file facing -z, read in its own right frame, says the same.
    assert _cues(vertices * [-1, 1, -1], faces, "y", "-z")[1] == pytest.approx(bulk, abs=0.05)


def test_a_cartoon_facing_away_is_rigged_head_forward(cartoon):
    vertices, faces, head = cartoon
    rig = autorig.rig((vertices * [-1, 1, -1], faces), "quadruped")
    assert (rig.info["up"], rig.info["front"]) == ("y", "-z")
    joint = rig.joints[rig.names.index("head")] * [-1, 1, -1]
    assert np.linalg.norm(joint - head) < 0.5 * CARTOON["head"] + 0.2


# A fox-like animal (autorig.samples' primitives through the benchmark's generator, proportions written out here,
# not one of its seeded family): a long thin tail held out straight behind, reaching farther than the head,
# which the outline's cue reads the wrong way round (-0.29); long ears on top, the crest's place.
FOX = dict(girth=0.2, legs=0.45, neck=0.15, neck_rise=35.0, head=0.17, snout=0.3, ears="long", tail="thin",
           tail_length=1.3, head_back=0.0, elbow_back=0.1, wrist_forward=0.05, knee_forward=0.15, hock_back=0.2,
           chest=1.1, leg_thickness=0.35)


@pytest.fixture(scope="module")
def fox():
    vertices, faces, head, rump = build(FOX, resolution=64)
    return vertices, faces, head, rump


def test_the_share_and_crest_cues_find_the_fox_head_and_turn_with_it(fox):
    from autorig.embed.ends import weight_share_cue
    from autorig.embed.orient import crest_cue
    vertices, faces, _, _ = fox
    prepared = prepare(vertices, faces, "y", "z")
    _, graph = discretize(prepared)
    V = prepared.work_vertices
    share, crest = weight_share_cue(graph, V), crest_cue(V)
    assert share > 0.05 and crest > 0.5
    assert crest_cue(V * [-1, 1, -1]) == pytest.approx(-crest)
    assert crest_cue(V * 2.0 + [1.0, -3.0, 2.0]) == pytest.approx(crest)
    turned = prepare(vertices, faces, "y", "-z")
    _, turned_graph = discretize(turned)
    assert weight_share_cue(turned_graph, turned.work_vertices) == pytest.approx(-share, abs=0.02)


@pytest.mark.parametrize("turn, axes", [
    (lambda v: v * [-1, 1, -1], ("y", "-z")),
    (lambda v: np.c_[v[:, 2], v[:, 1], -v[:, 0]], ("y", "x")),
], ids=["facing -z", "facing +x"])
def test_a_fox_facing_away_is_detected_facing_away(fox, turn, axes):
    vertices, faces, head, rump = fox
    rig = autorig.rig((turn(vertices), faces), "quadruped")
    assert (rig.info["up"], rig.info["front"]) == axes
    joint = rig.joints[rig.names.index("head")]
    assert np.linalg.norm(joint - turn(head[None])[0]) < np.linalg.norm(joint - turn(rump[None])[0])


def test_the_embedding_front_back_difference_is_bounded():
    from autorig.embed.orient import bounded_costs
    costs = {("y", "z"): 2.19, ("y", "-z"): 2.48, ("y", "x"): 5.0, ("-y", "z"): 9.0}
    assert bounded_costs(costs, None) == costs
    bounded = bounded_costs(costs, 0.1)
    assert bounded[("y", "-z")] == pytest.approx(2.29) and bounded[("y", "z")] == 2.19
    assert bounded[("y", "x")] == 5.0 and bounded[("-y", "z")] == 9.0    # no opposite frame tried: unchanged
    assert bounded_costs(costs, 0.0)[("y", "-z")] == pytest.approx(2.19)
    # Lower bounds are bounded by the opposite frame's lower bound.
    floor = {("y", "z"): 1.0, ("y", "-z"): 2.0}
    assert bounded_costs({k: costs[k] for k in floor}, 0.5, floor) == {("y", "z"): 1.0, ("y", "-z"): 1.5}


# A dachshund-like animal (written out here, not one of the benchmark's seeded family): short legs under a long
# low body, a long snout carried low and a thick tapering tail that holds more of the body's outline behind the
# hips than the head does in front of the shoulders. On dev8 (the outline and bulk cues, the embedding's
# front/back difference counted in full) it came out reversed in all four turns of benchmarks/quadruped_axes.py.
DACHSHUND = dict(girth=0.18, legs=0.12, neck=0.15, neck_rise=10.0, head=0.13, snout=0.5, ears="long", tail="thick",
                 tail_length=1.0, head_back=0.0, elbow_back=0.12, wrist_forward=0.05, knee_forward=0.15,
                 hock_back=0.2, chest=1.15, leg_thickness=0.35)


@pytest.mark.parametrize("turn, axes", [
    (lambda v: v * [-1, 1, -1], ("y", "-z")),
    (lambda v: np.c_[v[:, 2], v[:, 1], -v[:, 0]], ("y", "x")),
], ids=["facing -z", "facing +x"])
def test_a_dachshund_facing_away_is_detected_facing_away(turn, axes):
    # A low animal is long for its height: the benchmark's finer grid keeps its short legs apart from its belly.
    vertices, faces, head, rump = build(DACHSHUND, resolution=112)
    rig = autorig.rig((turn(vertices), faces), "quadruped")
    assert (rig.info["up"], rig.info["front"]) == axes
    joint = rig.joints[rig.names.index("head")]
    assert np.linalg.norm(joint - turn(head[None])[0]) < np.linalg.norm(joint - turn(rump[None])[0])


def test_the_toes_cue_points_the_way_the_feet_do_and_turns_with_them(fox):
    """The generated fox's paws reach forward of its legs: the feet's cue says +z, turned round it says -z, and
    neither the units, the place nor the order of the faces changes it."""
    from autorig.embed.ends import toes_cue
    vertices, faces, _, _ = fox
    prepared = prepare(vertices, faces, "y", "z")
    _, graph = discretize(prepared)
    V, F = prepared.work_vertices, np.asarray(prepared.work_faces)
    toes = toes_cue(graph, V, F)
    assert toes > 0.5
    moved = graph.moved(graph.centers * 2.0 + [1.0, -3.0, 2.0], 2.0)
    assert toes_cue(moved, V * 2.0 + [1.0, -3.0, 2.0], F) == pytest.approx(toes)
    assert toes_cue(graph, V, F[::-1][:, [1, 2, 0]]) == pytest.approx(toes)
    turned = prepare(vertices, faces, "y", "-z")
    _, turned_graph = discretize(turned)
    assert toes_cue(turned_graph, turned.work_vertices, np.asarray(turned.work_faces)) == pytest.approx(-toes, abs=0.05)


SHARED = ROOT.parent / "shared"


@pytest.mark.skipif(not (SHARED / "data" / "train" / "0ad_wolf").is_dir(), reason="needs ../shared")
@pytest.mark.parametrize("pose", ["head low", "walk, head low"])
def test_a_wolf_with_its_head_low_is_rigged_facing_forward(pose):
    """0 A.D.'s wolf re-posed through its artist's weights with its neck turned down (benchmarks/animal_poses.py),
    axes detected: the outline, the bulk, the weight and the crest all read its withers and tail as the head
    (reversed before the feet's cue); its toes still point forward, and its head joint is in its head."""
    import animal_poses
    from autorig.learn.examples import read_example
    from autorig.template import load_template
    example = read_example(SHARED / "data" / "train" / "0ad_wolf", load_template(ROOT / "templates" / "handset" /
                                                                                   "quadruped.json"))
    posed = animal_poses.posed_example(example, pose)
    rig = autorig.rig((np.asarray(posed.vertices, float), posed.faces), "quadruped")
    assert (rig.info["up"], rig.info["front"]) == ("y", "z")
    head = rig.joints[rig.names.index("head")]
    truth = {k: np.asarray(posed.positions[j], float) for k, j in posed.key_of.items()}
    assert np.linalg.norm(head - truth["head"]) < min(np.linalg.norm(head - truth[k]) for k in truth
                                                     if k.startswith("back_") or k.startswith("tail"))


def test_the_sides_penalty_reads_each_foot_against_its_trunk_joint():
    """A foot's end costs nothing a margin to its own side of its hips or chest, more the nearer it comes to the
    mid-plane and beyond it; read from the parent's x, so that moving the whole body along x changes nothing and
    its mirror image costs the same. Heads and tails have no side (an animal turns its head)."""
    from autorig.embed.penalties import SIDE_MARGIN, SIDE_UNIT, side_penalty, side_rules
    from autorig.template import load_template
    x = np.array([-0.2, -0.05, 0.0, 0.01, 0.05, 0.2])
    left = side_penalty(1, 0.0, x)
    assert np.all(np.diff(left) <= 0) and left[-1] == 0.0 and left[-2] == 0.0
    assert left[2] == pytest.approx(SIDE_MARGIN / SIDE_UNIT)
    assert np.allclose(side_penalty(-1, 0.0, -x), left)
    for rule in (1, -1):
        assert np.allclose(side_penalty(rule, 0.3, x + 0.3), side_penalty(rule, 0.0, x))
    quadruped = load_template("quadruped")
    reduced = quadruped.reduced()
    rules = dict(zip((quadruped.names[j] for j in reduced.joints), side_rules(quadruped, reduced)))
    assert rules["front_left_paw_end"] == rules["back_left_paw_end"] == 1
    assert rules["front_right_paw_end"] == rules["back_right_paw_end"] == -1
    assert rules["head_end"] == rules["tail_end"] == rules["hips"] == 0


@pytest.mark.skipif(not (SHARED / "data" / "train" / "0ad_boar").is_dir(), reason="needs ../shared")
def test_a_boar_walking_with_its_snout_on_the_ground_has_its_legs_in_its_legs():
    """0 A.D.'s boar walking with its head low (benchmarks/animal_poses.py: its snout reaches the ground between its
    front feet), axes given: without the sides penalty both front legs' chains ended on the snout and tusks and
    the hind legs' in the front feet (every paw 24-58 % of its length from its artist's); each paw and the head
    is now nearest its own artist's joint."""
    import animal_poses
    from animals import Animal, score
    from autorig.learn.examples import read_example
    from autorig.template import load_template
    example = read_example(SHARED / "data" / "train" / "0ad_boar", load_template(ROOT / "templates" / "handset" /
                                                                                   "quadruped.json"))
    posed = animal_poses.posed_example(example, "walk, head low")
    rig = autorig.rig((np.asarray(posed.vertices, float), posed.faces), "quadruped",
                      autorig.RigOptions(up=example.up, front=example.front))
    truth = {k: np.asarray(posed.positions[j], float) for k, j in posed.key_of.items()}
    result = score(dict(zip(rig.names, np.asarray(rig.joints, float))), truth, Animal("boar", "0ad", "boar",
                                                                                     example).extent)
    assert {end: e["nearest"] for end, e in result["ends"].items()} == {end: end for end in result["ends"]}
    assert result["structure"]


@pytest.mark.skipif(not (SHARED / "data" / "train" / "0ad_rhino").is_dir(), reason="needs ../shared")
def test_a_walking_rhino_is_read_upright():
    """0 A.D.'s rhino walking (benchmarks/animal_poses.py), axes detected: its legs apart, the embedding upside
    down cost 0.24 less than upright, and it was rigged on its back; its legs hang below its trunk
    (``thin_above``: below upright, as far above upside down), and it is rigged upright."""
    import animal_poses
    from autorig.embed.orient import thin_above
    from autorig.learn.examples import read_example
    from autorig.template import load_template
    example = read_example(SHARED / "data" / "train" / "0ad_rhino", load_template(ROOT / "templates" / "handset" /
                                                                                    "quadruped.json"))
    posed = animal_poses.posed_example(example, "walk")
    vertices, faces = np.asarray(posed.vertices, float), posed.faces
    _, graph = discretize(prepare(vertices, faces, "y", "z"))
    upright = thin_above(graph)
    upside_down = thin_above(graph.moved(graph.centers * np.array([-1.0, -1.0, 1.0]), 1.0))
    assert upright < -0.05 and upside_down == pytest.approx(-upright)
    rig = autorig.rig((vertices, faces), "quadruped")
    assert (rig.info["up"], rig.info["front"]) == ("y", "z")
