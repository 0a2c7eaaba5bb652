"""Landmarks read off the mesh (``autorig.readoff.landmarks``) and the placement's stretch about the neck."""
import numpy as np
import pytest
import trimesh

from autorig.readoff.landmarks import neck_fraction
from autorig.input.mesh import prepare
from autorig.pipeline import discretize
from autorig.embed.placement import MAX_NECK_SHIFT, neck_heights
from autorig.samples import Proportions, mannequin


def _field(vertices, faces):
    field, _ = discretize(prepare(vertices, faces, "y", "z", checked=True))
    return field


def _true_neck(sample) -> float:
    lo, hi = sample.vertices[:, 1].min(), sample.vertices[:, 1].max()
    return (sample.joints["neck"][1] - lo) / (hi - lo)


@pytest.mark.parametrize("pose", ["t", "a", "down"])
def test_the_neck_is_found_where_the_mannequin_has_it_in_every_rest_pose(pose):
    sample = mannequin(pose, resolution=64)
    found = neck_fraction(_field(sample.vertices, sample.faces))
    assert found is not None and abs(found - _true_neck(sample)) < 0.04


def test_a_large_head_puts_the_neck_lower():
    adult = mannequin("t", resolution=64)
    big_head = mannequin("t", Proportions(head=0.36), resolution=64)
    found_adult = neck_fraction(_field(adult.vertices, adult.faces))
    found_big = neck_fraction(_field(big_head.vertices, big_head.faces))
    expected = _true_neck(adult) - _true_neck(big_head)
    assert expected > 0.05
    assert abs((found_adult - found_big) - expected) < 0.03


def test_a_body_without_a_neck_has_none():
    box = trimesh.creation.box(extents=(0.5, 1.8, 0.3))
    assert neck_fraction(_field(np.asarray(box.vertices), np.asarray(box.faces))) is None


def test_the_stretch_about_the_neck_keeps_the_feet_and_the_top_and_moves_the_neck():
    heights = np.array([0.0, 0.4, 0.85, 0.95, 1.0])
    moved = neck_heights(heights, 0.85, 0.75)
    assert moved[0] == 0 and moved[-1] == pytest.approx(1.0) and moved[2] == pytest.approx(0.75)
    assert moved[1] == pytest.approx(0.4 * 0.75 / 0.85)
    assert np.all(np.diff(moved) > 0)
    # a misread neck far from the template's moves it no further than MAX_NECK_SHIFT
    assert neck_heights(np.array([0.85]), 0.85, 0.3)[0] == pytest.approx(0.85 - MAX_NECK_SHIFT)


def test_a_template_file_keeps_its_learned_neck_and_checks_it():
    import json
    from dataclasses import replace

    from autorig.template import TemplateError, load_template, template_from_dict
    biped = load_template("biped")
    J = len(biped.names)
    template = replace(biped, placement={"alpha": [0.5] * J, "extent": [1.0, 1.8, 0.4], "neck": 0.86})
    data = json.loads(json.dumps(template.to_dict()))
    assert template_from_dict(data).placement["neck"] == pytest.approx(0.86)
    with pytest.raises(TemplateError, match="neck"):
        template_from_dict({**data, "placement": {**data["placement"], "neck": 2.5}})


class _Profile:
    """A field stand-in: a body of round cross-sections about the y axis, radius(y) given, one unit tall."""

    def __init__(self, radius):
        self.radius = radius
        self.surface_vertices = np.array([[-0.5, 0.0, -0.5], [0.5, 1.0, 0.5]])

    def depth(self, points):
        return self.radius(points[:, 1]) - np.hypot(points[:, 0], points[:, 2])


def test_a_neck_as_narrow_along_a_stretch_is_found_at_the_stretchs_middle_whichever_end_dips_by_a_hair():
    """A low-poly neck is a prism: its radius is the same from 0.74 to 0.86 of the height, and rounding makes
    one end or the other the narrowest by a hair. The deepest sample jumped from end to end (a 256-triangle
    figure's head moved 1.9 % of the height under 1e-6 noise); the floor's middle does not."""
    def body(tilt):
        def radius(y):
            trunk = np.where(y < 0.7, 0.3, np.where(y < 0.74, 0.3 - (y - 0.7) * 5, 0.1))
            head = np.where(y > 0.86, np.minimum(0.1 + (y - 0.86) * 5, 0.2), 0.1)
            neck = 0.1 + tilt * (y - 0.8)
            return np.where(y < 0.74, trunk, np.where(y > 0.86, head, neck))
        return _Profile(radius)
    found = [neck_fraction(body(tilt)) for tilt in (-1e-7, 1e-7)]
    assert found[0] == pytest.approx(0.8, abs=0.01) and found[1] == pytest.approx(0.8, abs=0.01)
    assert abs(found[0] - found[1]) < 0.005
