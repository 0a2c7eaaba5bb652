"""Legs read off the mesh (``autorig.readoff.legs``): the rings, the bend, the learned rules and the pipeline stage."""
from __future__ import annotations

import numpy as np
import pytest

import autorig
from autorig.errors import TemplateError
from autorig.readoff.legs import bend, legs_of, measure_legs, read_legs, sections
from autorig.input.mesh import prepare
from autorig.samples import mannequin, quadruped
from autorig.template import load_template, template_from_dict


def _canonical(sample):
    prepared = prepare(sample.vertices, sample.faces, "y", "z")
    joints = {n: prepared.to_canonical(np.asarray(p)[None])[0] for n, p in sample.joints.items()}
    return prepared, joints


@pytest.fixture(scope="module")
def template():
    return load_template("quadruped")


@pytest.mark.parametrize("build", ["dog", "long", "tall"])
def test_every_leg_measured_where_the_sample_has_it(template, build):
    """Four legs, each standing apart from the ground to between its wrist (hock) and its shoulder (hip),
    its rings centred on the sample's own leg, and the back leg bending at the hock."""
    sample = quadruped(build)
    prepared, truth = _canonical(sample)
    guess = np.array([truth[n] for n in template.names])
    legs = measure_legs(prepared.work_vertices, prepared.work_faces, guess, template)
    assert all(leg is not None for leg in legs)
    for leg in legs:
        names = [template.names[j] for j in leg.chain]
        root, lower = truth[names[0]], truth[names[2]]
        assert lower[1] < leg.free < root[1] + 0.02, (names[0], leg.free)
        assert leg.top >= leg.free
        centre, width = leg.across(lower[1])
        assert np.all(np.abs(centre - lower[[0, 2]]) < np.maximum(width, 0.02)), (names[2], centre, lower)
        assert np.sign(centre[0]) == leg.side
        if names[0].startswith("back"):
            assert abs(bend(leg) - lower[1]) < 0.06, (names[2], bend(leg), lower[1])


def test_sections_are_rings_per_piece():
    """A cut through four legs gives four pieces; through the body, one."""
    sample = quadruped("dog")
    prepared, truth = _canonical(sample)
    low, body = sections(prepared.work_vertices, prepared.work_faces,
                         np.array([0.5 * truth["front_left_wrist"][1], truth["spine"][1]]))
    assert len(low) == 4
    assert len(body) == 1


def test_read_legs_needs_learned_rules_and_keeps_tips_with_their_paws(template):
    sample = quadruped("dog")
    prepared, truth = _canonical(sample)
    guess = np.array([truth[n] for n in template.names])
    bare = template_from_dict({k: v for k, v in template.to_dict().items() if k != "legs"})
    assert bare.legs is None
    np.testing.assert_array_equal(read_legs(guess, bare, prepared.work_vertices, prepared.work_faces), guess)
    read = read_legs(guess, template, prepared.work_vertices, prepared.work_faces)
    for chain in legs_of(template):
        paw, tip = chain[-2], chain[-1]
        np.testing.assert_allclose(read[tip] - read[paw], guess[tip] - guess[paw], atol=1e-12)
    moved = [template.names[j] for j in range(len(guess)) if not np.allclose(read[j], guess[j])]
    assert any(n.endswith("_knee") for n in moved) and any(n.endswith("_ankle") for n in moved)
    assert not any(n.endswith("_paw") or n in ("hips", "spine", "chest", "neck", "head") for n in moved)


@pytest.mark.parametrize("build", ["dog", "long", "tall"])
def test_an_elbow_placed_above_the_leg_is_read_back_onto_it(template, build):
    """A front elbow the placement put up at the shoulder (as it did on OpenClonk's mooq, whose short legs join
    the body low) is read back down onto the leg: below where the leg joins the body, within its ring, and near
    the sample's own elbow (its artist's shares of the free height: 0.76-0.95)."""
    sample = quadruped(build)
    prepared, truth = _canonical(sample)
    guess = np.array([truth[n] for n in template.names])
    for side in ("left", "right"):
        guess[template.names.index(f"front_{side}_elbow")] = truth[f"front_{side}_shoulder"]
    read = read_legs(guess, template, prepared.work_vertices, prepared.work_faces)
    height = float(np.ptp(prepared.work_vertices[:, 1]))
    for leg in measure_legs(prepared.work_vertices, prepared.work_faces, guess, template):
        name = template.names[leg.chain[1]]
        if not name.endswith("_elbow"):
            continue
        elbow = read[leg.chain[1]]
        assert elbow[1] < leg.free, (name, elbow[1], leg.free)
        centre, width = leg.across(elbow[1])
        assert np.all(np.abs(elbow[[0, 2]] - centre) <= width / 2), (name, elbow, centre, width)
        assert abs(elbow[1] - truth[name][1]) / height < 0.05, (name, elbow[1], truth[name][1])


def test_legs_round_trip_and_bad_rules(template):
    data = template.to_dict()
    assert template_from_dict(data).legs == template.legs
    for bad in ({"nose": {"offset": [0, 0]}}, {"back_left_knee": {"offset": [0]}},
                {"back_left_knee": {"height": [1, 2], "offset": [0, 0]}}, ["back_left_knee"],
                {"front_left_wrist": {"ratio": [1, 2], "offset": [0, 0]}}):
        with pytest.raises(TemplateError, match="legs"):
            template_from_dict({**data, "legs": bad})


def test_the_stage_runs_for_four_legged_templates_only():
    """The biped pays nothing for it: no stage, no time."""
    dog = quadruped("dog")
    rig = autorig.rig((dog.vertices, dog.faces), "quadruped", autorig.RigOptions(up="y", front="z"))
    assert "legs" in rig.timings
    height = float(np.ptp(dog.vertices[:, 1]))
    for name in ("back_left_knee", "back_left_ankle", "front_left_wrist"):
        assert np.linalg.norm(rig.joint(name) - dog.joints[name]) / height < 0.1, name
    person = mannequin()
    assert "legs" not in autorig.rig((person.vertices, person.faces), "biped").timings


@pytest.mark.parametrize("build", ["dog", "long", "tall"])
def test_confidence_tells_a_right_animal_from_a_backwards_one(build):
    """The quadruped's confidence is calibrated on rigs judged by their limbs, not by where each species'
    artists put the trunk joints: a rig the right way round trusts itself, one made facing backwards (left and
    right, head and tail swapped: its limbs more than 20 % off) does not. Before, every quadruped scored 0.01."""
    sample = quadruped(build)
    height = float(np.ptp(sample.vertices[:, 1]))
    for front, right in (("z", True), ("-z", False)):
        rig = autorig.rig((sample.vertices, sample.faces), "quadruped", autorig.RigOptions(up="y", front=front))
        worst = max(np.linalg.norm(rig.joint(n) - sample.joints[n]) / height for n in rig.names
                    if n in sample.joints and not n.endswith("_end") and n not in ("hips", "spine", "chest", "neck"))
        assert (worst < 0.25) if right else (worst > 0.2), (front, worst)
        assert (rig.info["confidence"] >= 0.5) == right, (front, rig.info["confidence"])


def test_a_foot_on_the_trunk_is_no_leg(template):
    """A custom template whose foot hangs straight from a branching joint has no leg chain to read."""
    data = template.to_dict()
    for joint in data["joints"]:
        if joint["name"] == "back_left_paw_end":
            joint["parent"] = "hips"
    odd = template_from_dict(data)
    chains = [[odd.names[j] for j in chain] for chain in legs_of(odd)]
    assert len(chains) == 3 and all(chain[-1] != "back_left_paw_end" for chain in chains)


def test_the_back_over_a_leg_is_not_a_tail_raised_over_it():
    """``highest_crossings``: a vertical line meets a unit cube's top at 1 and misses beside it; the back over a
    leg (``top``) stays the back's height when a thin pole (a tail held up) rises over one corner of the ring."""
    from autorig.readoff.legs import highest_crossings
    import trimesh
    cube = trimesh.creation.box(extents=(1, 1, 1))
    cube.apply_translation((0, 0.5, 0))
    tops = highest_crossings(np.asarray(cube.vertices), np.asarray(cube.faces),
                             np.array([[0.0, 0.0], [0.3, -0.2], [2.0, 0.0]]))
    assert tops[:2] == pytest.approx([1.0, 1.0])
    assert tops[2] == -np.inf
    sample = quadruped("dog")
    prepared, truth = _canonical(sample)
    template = load_template("quadruped")
    guess = np.array([truth[n] for n in template.names])
    V, F = prepared.work_vertices, prepared.work_faces
    plain = measure_legs(V, F, guess, template)[2]
    centre, width = plain.centres[-1], plain.widths[-1]
    pole = trimesh.creation.box(extents=(0.02, 0.6, 0.02))
    pole.apply_translation((centre[0] + 0.25 * width[0], plain.top + 0.3, centre[1] + 0.25 * width[1]))
    raised = measure_legs(np.vstack([V, pole.vertices]), np.vstack([F, np.asarray(pole.faces) + len(V)]), guess,
                          template)[2]
    assert plain.free < plain.top < truth[template.names[plain.chain[0]]][1] + 0.2
    assert raised.top == pytest.approx(plain.top, abs=0.01)


def test_a_head_chain_short_of_the_snout_counts_against_the_rig(template):
    """``ends_short``: the sample dog rigged with its own joints reaches its snout and its tail's end (within a
    few % of its length); its head chain ending at the neck (as one that went into a horn or a tusk does) falls
    short by the head's length; the biped, whose front is its toes or its belly, is never judged by it."""
    from autorig.confidence import ends_short
    sample = quadruped("dog")
    prepared, truth = _canonical(sample)
    V = prepared.work_vertices
    joints = np.array([truth[n] for n in template.names])
    assert ends_short(V, joints, template) < 0.06
    short = joints.copy()
    head, head_end, neck = (template.names.index(n) for n in ("head", "head_end", "neck"))
    short[[head, head_end]] = joints[neck]
    length = float(np.ptp(V[:, 2]))
    assert ends_short(V, short, template) > ends_short(V, joints, template) + 0.5 * (
        joints[head_end, 2] - joints[neck, 2]) / length
    biped = load_template("biped")
    assert ends_short(V, np.zeros((len(biped.names), 3)), biped) == 0.0


def test_short_legs_are_no_wrong_proportions(template):
    """A four-legged rig's legs are read off the mesh, so their length is the animal's own: the confidence's
    ``proportions`` (bone lengths against the examples') does not count them, and a dachshund-legged dog's rig
    is as far from the examples' proportions as the dog's. Its neck made twice as long still counts."""
    from autorig.confidence import features
    sample = quadruped("dog")
    _, truth = _canonical(sample)
    joints = np.array([truth[n] for n in template.names])
    short = joints.copy()
    for chain in legs_of(template):     # every leg squeezed to 0.4 of its length towards its root
        short[chain[1:]] = joints[chain[0]] + 0.4 * (joints[chain[1:]] - joints[chain[0]])
    parts = {"limbs": 1.0, "extra": 1.0, "inside": 1.0, "symmetry": 1.0, "search": 1.0}
    sigma = np.full(len(template.names), 0.3)
    def proportions(j, t=template):
        return features(parts, 0.1, j, t, sigma, np.zeros((0, 3)))["proportions"]
    assert proportions(short) == pytest.approx(proportions(joints), abs=1e-12)
    longer = joints.copy()
    neck, chest = template.names.index("neck"), template.names.index("chest")
    moved = [neck] + [j for j in range(len(joints)) if neck in _ancestors(template, j)]
    longer[moved] += joints[neck] - joints[chest]
    assert proportions(longer) > proportions(joints) + 0.1
    bare = template_from_dict({k: v for k, v in template.to_dict().items() if k != "legs"})
    assert proportions(short, bare) > proportions(joints, bare) + 1.0


def _ancestors(template, j):
    out = []
    while template.parents[j] >= 0:
        j = int(template.parents[j])
        out.append(j)
    return out


def _leg(fore_aft):
    """A measured leg 0.4 tall whose rings' fore-aft widths are ``fore_aft(level)`` (sides 0.05 wide)."""
    from autorig.readoff.legs import LEVELS, Leg
    levels = LEVELS[LEVELS <= 0.4]
    widths = np.stack([np.full(len(levels), 0.05), [fore_aft(y) for y in levels]], axis=1)
    return Leg(chain=[0, 1, 2, 3, 4], side=1.0, levels=levels, centres=np.zeros((len(levels), 2)), widths=widths,
               free=0.4, top=0.8)


def test_a_hoofed_legs_wrist_sits_higher_than_a_pawed_ones():
    """The shipped quadruped reads a wrist's height off the foot (``foot_features``): a hoof no longer than the
    cannon above it puts the carpus half-way up the leg, a paw twice as long as the leg's thinnest just above
    the paw (issue 37: the template's proportions had every hoofed animal's wrist 5-14 % of its extent low and
    every dog's, cat's and bear's 2-6 % high)."""
    from autorig.readoff.legs import RATIO_RANGE, foot_features
    rule = load_template("quadruped").legs["front_left_wrist"]["ratio"]
    hoof = _leg(lambda y: 0.04 if y < 0.2 else 0.04 + 0.3 * (y - 0.2))
    paw = _leg(lambda y: 0.12 - 0.8 * y if y < 0.1 else 0.04 + 0.15 * (y - 0.1))
    np.testing.assert_allclose(foot_features(hoof)[1:], [0.1, 1.0])
    assert foot_features(paw)[1] == pytest.approx(0.24) and foot_features(paw)[2] > 2.0
    hoofed, pawed = (float(np.clip(np.dot(rule, foot_features(leg)), *RATIO_RANGE)) for leg in (hoof, paw))
    assert hoofed > 0.4 and pawed < 0.3 and hoofed - pawed > 0.2


def test_a_hoof_tipped_onto_its_toe_is_read_as_the_hoof_standing():
    """A leg swung back stands on its toe: the rings at the ground are the toe's sliver, not the leg's thinnest,
    and the hoof reads as a hoof (its wrist where the standing hoof's is), not as a foot six times its leg."""
    from autorig.readoff.legs import FOOT_LEVEL, foot_features
    standing = _leg(lambda y: 0.04 if y < 0.2 else 0.04 + 0.3 * (y - 0.2))
    tipped = _leg(lambda y: 0.007 if y < FOOT_LEVEL / 2 else 0.04 if y < 0.2 else 0.04 + 0.3 * (y - 0.2))
    np.testing.assert_allclose(foot_features(tipped), foot_features(standing))


SHARED_MESHES = __import__("pathlib").Path(__file__).resolve().parents[1].parent / "shared" / "data" / "meshes"


@pytest.mark.skipif(not SHARED_MESHES.is_dir(), reason="shared data (../shared/data) is not present")
@pytest.mark.parametrize("name, front", [("spot", "-z"), ("cow", "x")])
def test_a_wrist_read_off_the_foot_stays_between_its_paw_and_its_elbow(name, front):
    """A cartoon cow's hoof is a bulb 3.6 times as long as its leg's thinnest, past any example's foot: the
    wrist's share, read off the foot, fell to the ground under the paw. It is kept within the examples' shares
    and above the paw."""
    rig = autorig.rig(SHARED_MESHES / f"{name}.obj", "quadruped", autorig.RigOptions(up="y", front=front))
    for side in ("left", "right"):
        paw, wrist, elbow = (rig.joint(f"front_{side}_{j}")[1] for j in ("paw", "wrist", "elbow"))
        assert paw < wrist < elbow


def test_a_straight_legs_bend_does_not_jump_when_its_rings_move_by_a_millionth():
    """The bend is where the leg's rings lie farthest aft of its chord; on a straight leg (a hind leg lifted off
    the ground in a walk) every ring is aft by a rounding error, and the level of the farthest jumped as the
    floats fell (0 A.D.'s fox walking with its head low: the bend 0.065 or 0.085, its knee 1.6 % of the height
    apart). Rings aft by nearly the same share it; a leg that bends keeps its bend at its own ring."""
    from autorig.readoff.legs import Leg

    levels = np.round(np.arange(0.005, 0.6, 0.01), 3)
    straight = np.column_stack([np.zeros_like(levels), 0.1 + 0.05 * levels])

    def leg(centres):
        return Leg(chain=[0, 1, 2, 3], side=1.0, levels=levels, centres=centres,
                   widths=np.full((len(levels), 2), 0.05), free=float(levels[-1]), top=0.9)

    rng = np.random.default_rng(0)
    bends = [bend(leg(straight + rng.uniform(-1e-6, 1e-6, straight.shape))) for _ in range(5)]
    assert np.ptp(bends) < 0.005, bends
    hock = straight.copy()
    hock[:, 1] -= 0.04 * np.exp(-((levels - 0.245) / 0.05) ** 2)    # the leg's path farthest aft at 0.245
    assert abs(bend(leg(hock)) - 0.245) < 0.005
