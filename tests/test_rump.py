"""The tail's base read off the rump (``autorig.readoff.rump``): the trunk's end, whatever the tail does."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from autorig.discretize.surface import SurfaceQuery
from autorig.errors import TemplateError
from autorig.input.mesh import prepare
from autorig.readoff.rump import measure_rump, read_rump
from autorig.samples import QUADRUPED_PROPORTIONS, quadruped
from autorig.template import load_template, template_from_dict


@pytest.fixture(scope="module")
def template():
    return load_template("quadruped")


def _measured(tail: float, template):
    """(rump (x, end, middle, trunk) in metres, the mesh's rear end in metres, the sample's tail base [3] in the
    canonical frame, the prepared mesh, the truth [J, 3] canonical) of the sample dog with a tail this long."""
    sample = quadruped(replace(QUADRUPED_PROPORTIONS["dog"], tail=tail))
    prepared = prepare(sample.vertices, sample.faces, "y", "z")
    truth = np.array([prepared.to_canonical(np.asarray(sample.joints[n])[None])[0] for n in template.names])
    query = SurfaceQuery(prepared.work_vertices, prepared.work_faces)
    rump = measure_rump(lambda p: query.closest(p)[0], prepared.work_vertices, truth, template)
    height = float(np.ptp(sample.vertices[:, 1]))
    return rump, height, prepared, truth


def test_a_longer_tail_moves_the_box_not_the_rump(template):
    """The dog with a stub of a tail and with one twice its own: the box's back end moves back by a third of
    the height, the rump's end (and so the tail's base) by less than 2 %."""
    (x1, end1, mid1, trunk1), h1, p1, t1 = _measured(0.08, template)
    (x2, end2, mid2, trunk2), h2, p2, t2 = _measured(0.72, template)
    assert abs(h1 - h2) < 1e-3 * h1    # the tail hangs above the ground: the same height, the same canonical scale
    back1, back2 = p1.work_vertices[:, 2].min(), p2.work_vertices[:, 2].min()
    # The canonical frame is centred on the box: the rump is measured against the sample's own hips.
    hips = template.names.index("hips")
    back1, back2 = back1 - t1[hips, 2], back2 - t2[hips, 2]
    end1, end2 = end1 - t1[hips, 2], end2 - t2[hips, 2]
    assert back1 - back2 > 0.3
    assert abs(end1 - end2) < 0.02 and abs(mid1 - mid2) < 0.02 and abs(trunk1 - trunk2) < 0.01
    j = template.names.index("tail_base")
    # The sample's tail base sits on the mid-plane, within a trunk's depth of the rump's end.
    assert abs(x1) < 0.01
    assert abs(t1[j, 2] - t1[hips, 2] - end1) < trunk1


def test_the_rule_moves_the_tail_base_and_nothing_else(template):
    _, _, prepared, truth = _measured(0.36, template)
    query = SurfaceQuery(prepared.work_vertices, prepared.work_faces)
    depth = lambda p: query.closest(p)[0]    # noqa: E731
    bare = replace(template, legs={k: v for k, v in template.legs.items() if "rump" not in v})
    np.testing.assert_array_equal(read_rump(truth, bare, depth, prepared.work_vertices), truth)
    x, end, middle, trunk = measure_rump(depth, prepared.work_vertices, truth, template)
    ruled = replace(template, legs={**template.legs, "tail_base": {"rump": [0.5, -0.25]}})
    read = read_rump(truth, ruled, depth, prepared.work_vertices)
    j = template.names.index("tail_base")
    np.testing.assert_allclose(read[j], [x, middle - 0.25 * trunk, end + 0.5 * trunk])
    others = np.arange(len(truth)) != j
    np.testing.assert_array_equal(read[others], truth[others])


def test_rump_rule_round_trip_and_bad_rules(template):
    data = template.to_dict()
    legs = {**data["legs"], "tail_base": {"rump": [-0.3, 0.2]}}
    assert template_from_dict({**data, "legs": legs}).legs["tail_base"] == {"rump": [-0.3, 0.2]}
    for bad in ({"tail_base": {"rump": [1]}}, {"tail_base": {"rump": [1, 2], "offset": [0, 0]}},
                {"tail_base": {"rump": "back"}}):
        with pytest.raises(TemplateError, match="legs"):
            template_from_dict({**data, "legs": {**data["legs"], **bad}})
