"""The held-out animals of ``benchmarks/quadruped_axes.py``: closed shapes, the same for the same seed, the head and
the rump where the benchmark judges rigs against them, and its verdict on rigs facing either way."""
from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from quadruped_axes import FAMILIES, TURNS, build, draw, family, judge  # noqa: E402

from autorig.discretize.distance import SurfaceQuery  # noqa: E402


@pytest.fixture(scope="module", params=FAMILIES)
def animal(request):
    return family(request.param, 1, seed=26, resolution=40)[0]


def test_each_animal_is_one_closed_surface(animal):
    edges = np.sort(animal.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)
    assert animal.vertices[:, 1].min() == pytest.approx(0.0)


def test_the_head_and_rump_are_inside_at_either_end(animal):
    winding = SurfaceQuery(animal.vertices, animal.faces).winding(np.array([animal.head, animal.rump]))
    assert np.all(winding > 0.5)
    assert animal.head[2] > 0 > animal.rump[2]


def test_the_same_seed_gives_the_same_animals_and_another_seed_others():
    first = family("cartoon", 2, seed=26, resolution=40)
    again = family("cartoon", 2, seed=26, resolution=40)
    other = family("cartoon", 2, seed=27, resolution=40)
    assert all(np.array_equal(a.vertices, b.vertices) for a, b in zip(first, again))
    assert first[0].params != other[0].params
    # The families differ in what they are about: a cartoon's head is far bigger than a realistic animal's.
    rng = np.random.default_rng(0)
    assert min(draw("cartoon", rng)["head"] for _ in range(20)) > max(draw("realistic", rng)["head"] for _ in range(20))


def test_a_rig_is_judged_by_where_its_head_joint_is():
    p = draw("realistic", np.random.default_rng(1))
    vertices, faces, head, rump = build(p, resolution=40)
    animal = SimpleNamespace(head=head, rump=rump)
    for _, turn, axes in TURNS:
        def rig(at, up=axes[0]):
            return SimpleNamespace(info={"up": up}, names=["hips", "head"], joints=turn(np.array([rump, at])))
        assert judge(rig(head + [0, 0, -0.1]), animal, turn, axes) == "right"
        assert judge(rig(rump + [0, 0.1, 0]), animal, turn, axes) == "reversed"
        assert judge(rig(head, up="-" + axes[0]), animal, turn, axes) == "wrong up"
