"""The head read off the snout (``autorig.readoff.head``): a share of the way from the front paws to the snout's end."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from autorig.discretize.distance import SurfaceQuery
from autorig.errors import TemplateError
from autorig.readoff.head import STEP, measure_head, read_head
from autorig.input.mesh import prepare
from autorig.samples import QUADRUPED_PROPORTIONS, quadruped
from autorig.template import load_template, template_from_dict


@pytest.fixture(scope="module")
def template():
    return load_template("quadruped")


def _dog(head: float, template):
    """(depth function, prepared mesh, truth [J, 3] in the canonical frame) of the sample dog with a head this
    long (metres)."""
    sample = quadruped(replace(QUADRUPED_PROPORTIONS["dog"], head=head))
    prepared = prepare(sample.vertices, sample.faces, "y", "z")
    truth = np.array([prepared.to_canonical(np.asarray(sample.joints[n])[None])[0] for n in template.names])
    query = SurfaceQuery(prepared.work_vertices, prepared.work_faces)
    return (lambda p: query.closest(p)[0]), prepared, truth


def test_the_snout_is_the_front_of_the_mesh_and_follows_a_longer_head(template):
    """The dog's snout is its frontmost point; a head half as long again puts the measured snout further ahead
    of the paws, and the head column is found inside the mesh between the paws and the snout."""
    tips = []
    for head in (0.2, 0.3):
        depth, prepared, truth = _dog(head, template)
        x, paws, (_, _, tip), column = measure_head(depth, prepared.work_vertices, truth, template)
        assert abs(x) < 0.01
        assert prepared.work_vertices[:, 2].max() - 2 * STEP <= tip <= prepared.work_vertices[:, 2].max()
        deepest, thickness = column((paws + tip) / 2)
        assert thickness > STEP and prepared.work_vertices[:, 1].min() < deepest < prepared.work_vertices[:, 1].max()
        tips.append(tip - paws)
    assert tips[1] - tips[0] > 0.05


def _short_of_the_snout(truth, template, by: float):
    """``truth`` [J, 3] with the head chain's end pulled back along the back by ``by`` (heights), as an
    embedding that stopped in the neck or a tusk leaves it."""
    short = truth.copy()
    short[template.names.index("head_end"), 2] -= by
    return short


def test_a_chain_that_reached_the_snout_keeps_its_head(template):
    """The sample dog's own head chain ends at its snout: the rule leaves every joint; the same chain ending a
    tenth of the height short of the snout has its head moved."""
    depth, prepared, truth = _dog(0.26, template)
    ruled = replace(template, legs={**template.legs, "head": {"snout": [0.4, 0.1]}})
    np.testing.assert_array_equal(read_head(truth, ruled, depth, prepared.work_vertices), truth)
    short = _short_of_the_snout(truth, template, 0.1)
    assert np.any(read_head(short, ruled, depth, prepared.work_vertices) != short)


def test_the_rule_moves_the_head_and_keeps_the_neck_between(template):
    depth, prepared, truth = _dog(0.26, template)
    truth = _short_of_the_snout(truth, template, 0.1)
    bare = replace(template, legs={k: v for k, v in template.legs.items() if "snout" not in v})
    np.testing.assert_array_equal(read_head(truth, bare, depth, prepared.work_vertices), truth)
    x, paws, (_, _, tip), column = measure_head(depth, prepared.work_vertices, truth, template)
    names = template.names
    head, neck, chest = names.index("head"), names.index("neck"), names.index("chest")
    for k, m in ((0.4, 0.1), (1.2, -0.2)):
        ruled = replace(template, legs={**template.legs, "head": {"snout": [k, m]}})
        read = read_head(truth, ruled, depth, prepared.work_vertices)
        z = tip - k * (tip - paws)
        deepest, thickness = column(z)
        np.testing.assert_allclose(read[head], [x, deepest + m * thickness, z])
        assert min(read[chest, 2], read[head, 2]) <= read[neck, 2] <= max(read[chest, 2], read[head, 2])
        moved = np.any(read != truth, axis=1)
        assert set(np.nonzero(moved)[0]) <= {head, neck}
    # Far back (k = 1.2, behind the paws) the head lands behind the sample's neck joint: the neck goes half-way to the chest.
    np.testing.assert_allclose(read[neck], (read[chest] + read[head]) / 2)


def test_head_rule_round_trip_and_bad_rules(template):
    data = template.to_dict()
    legs = {**data["legs"], "head": {"snout": [0.6, 0.1]}}
    assert template_from_dict({**data, "legs": legs}).legs["head"] == {"snout": [0.6, 0.1]}
    for bad in ({"head": {"snout": [1]}}, {"head": {"snout": [1, 2], "rump": [0, 0]}},
                {"head": {"snout": [1, 2], "offset": [0, 0]}}, {"head": {"snout": "front"}}):
        with pytest.raises(TemplateError, match="legs"):
            template_from_dict({**data, "legs": {**data["legs"], **bad}})
