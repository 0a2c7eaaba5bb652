"""Messy real-world input: scale, orientation, loose parts, holes, inward faces, shapes that are no biped,
and broken templates."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import autorig
from autorig.confidence import STRICT_THRESHOLD
from autorig.errors import RigFailedError, TemplateError
from autorig.samples import mannequin
from autorig.template import template_from_dict


@pytest.fixture(scope="module")
def sample():
    return mannequin(pose="a")


@pytest.fixture(scope="module")
def reference(sample):
    return autorig.rig((sample.vertices, sample.faces), "biped")


@pytest.mark.parametrize("factor", [0.001, 1000.0])
def test_same_rig_at_any_scale(sample, reference, factor):
    scaled = autorig.rig((sample.vertices * factor, sample.faces), "biped")
    np.testing.assert_allclose(scaled.joints / factor, reference.joints, atol=1e-9)
    np.testing.assert_allclose(scaled.weights, reference.weights, atol=1e-9)


def test_z_up_file_is_detected(sample, reference):
    # (x, y, z)_file = (x, -z, y)_canonical: Z up, facing -y.
    V = np.c_[sample.vertices[:, 0], -sample.vertices[:, 2], sample.vertices[:, 1]]
    lying = autorig.rig((V, sample.faces), "biped")
    assert (lying.info["up"], lying.info["front"]) == ("z", "-y")
    back = np.c_[lying.joints[:, 0], lying.joints[:, 2], -lying.joints[:, 1]]
    # The field is sampled in the file's own axes, so the rig is close, not bit-identical.
    np.testing.assert_allclose(back, reference.joints, atol=0.02 * 1.7)


def test_inward_facing_mesh_rigs_like_outward(sample, reference):
    flipped = autorig.rig((sample.vertices, sample.faces[:, ::-1]), "biped")
    # Turned back outward, the triangles list their corners in another order: equal up to rounding.
    np.testing.assert_allclose(flipped.joints, reference.joints, atol=1e-3 * 1.7)


def test_loose_parts_are_weighted_to_the_bones_they_sit_by(sample):
    """An eye inside the head and a button floating in front of the chest, as separate pieces."""
    head = sample.joints["head"] + np.array([0.03, 0.08, 0.06])
    eye = trimesh.creation.icosphere(subdivisions=2, radius=0.015)
    chest = sample.joints["chest"] + np.array([0.0, 0.0, 0.2])
    button = trimesh.creation.icosphere(subdivisions=1, radius=0.01)
    V = np.vstack([sample.vertices, eye.vertices + head, button.vertices + chest])
    n0, n1 = len(sample.vertices), len(sample.vertices) + len(eye.vertices)
    F = np.vstack([sample.faces, eye.faces + n0, button.faces + n1])
    rig = autorig.rig((V, F), "biped", autorig.RigOptions(up="y", front="z"))
    np.testing.assert_allclose(rig.weights.sum(axis=1), 1.0, atol=1e-9)
    eye_joints = {rig.names[j] for j in np.argmax(rig.weights[n0:n1], axis=1)}
    assert eye_joints <= {"head", "neck"}, eye_joints
    button_joints = {rig.names[j] for j in np.argmax(rig.weights[n1:], axis=1)}
    assert button_joints <= {"chest", "spine", "neck", "left_shoulder", "right_shoulder"}, button_joints


def test_mesh_with_holes(sample, reference):
    """A scan with holes: every 25th triangle missing."""
    keep = np.arange(len(sample.faces)) % 25 != 0
    holed = autorig.rig((sample.vertices, sample.faces[keep]), "biped", autorig.RigOptions(up="y", front="z"))
    height = float(np.ptp(sample.vertices[:, 1]))
    assert np.abs(holed.joints - reference.joints).max() < 0.03 * height
    np.testing.assert_allclose(holed.weights.sum(axis=1), 1.0, atol=1e-9)


@pytest.mark.parametrize("bumps", [0, 6])
def test_limbless_torso_is_flagged(bumps):
    """A torso with no limbs, smooth or with a few small bumps, is refused or rigged with low confidence."""
    torso = trimesh.creation.capsule(height=1.0, radius=0.3, count=[24, 24])
    parts = [torso] + [trimesh.creation.icosphere(radius=0.06).apply_translation(
        [0.3 * np.cos(a), 0.3 * np.sin(a), 0.2 * np.sin(3 * a)]) for a in np.linspace(0, 2 * np.pi, bumps + 1)[:-1]]
    body = trimesh.util.concatenate(parts)
    try:
        rig = autorig.rig((body.vertices, body.faces), "biped", autorig.RigOptions(up="z", front="y"))
    except RigFailedError as error:
        assert "limb ends" in str(error)
        return
    assert rig.info["confidence"] < STRICT_THRESHOLD


def test_good_rig_is_trusted(reference):
    assert reference.info["confidence"] >= STRICT_THRESHOLD


names = st.sampled_from(["hips", "spine", "head", "a", "", "left_hand_end", "x" * 3])
joint = st.fixed_dictionaries({}, optional={
    "name": st.one_of(names, st.integers(), st.none()),
    "parent": st.one_of(names, st.none(), st.integers()),
    "position": st.one_of(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4), st.text(max_size=3),
                          st.none()),
})
template_data = st.one_of(
    st.fixed_dictionaries({}, optional={"joints": st.one_of(st.lists(joint, max_size=6), st.integers(), st.text()),
                                        "symmetry": st.one_of(st.lists(st.lists(names, max_size=3), max_size=3),
                                                              st.text()),
                                        "feet": st.one_of(st.lists(names, max_size=3), st.integers()),
                                        "fat": st.lists(names, max_size=3)}),
    st.lists(st.integers(), max_size=3), st.text(max_size=5), st.none())


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(template_data)
def test_broken_templates_give_a_template_error(data):
    try:
        template = template_from_dict(data, source="fuzz")
    except TemplateError as error:
        assert "\n" not in str(error)
        return
    # What is accepted is a usable tree: parents before children, finite positions.
    assert all(p < j for j, p in enumerate(template.parents))
    assert np.isfinite(template.positions).all()
    template.reduced()
