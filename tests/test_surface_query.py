"""The discretization's exact surface queries (autorig.discretize.surface.SurfaceQuery)."""
import numpy as np

from autorig.discretize import surface as surface_module
from autorig.discretize.surface import SurfaceQuery, _spread_bits


def test_queries_sent_along_the_morton_curve_answer_each_point_as_alone():
    """SurfaceQuery sends many points to libigl in Morton order (for the cache) and answers in the caller's
    order: the same answers, to the bit, as libigl's for the points as given."""
    from autorig.samples import mannequin
    sample = mannequin("a", resolution=40)
    surface = SurfaceQuery(sample.vertices, sample.faces)
    rng = np.random.default_rng(0)
    lo, hi = sample.vertices.min(axis=0), sample.vertices.max(axis=0)
    points = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (3000, 3))   # some outside the box
    assert len(points) >= surface_module.MORTON_MIN
    sq, _, nearest = surface._tree.squared_distance(surface.vertices, surface.faces, points)
    assert np.array_equal(surface.distance(points), np.sqrt(sq))
    assert np.array_equal(surface.nearest(points), nearest)
    depth, near = surface.closest(points)
    assert np.array_equal(near, nearest) and np.array_equal(np.abs(depth), np.sqrt(sq))
    assert np.array_equal(surface.winding(points), surface._winding_tree.winding_number(points, 1.5))
    order = surface._morton_order(points)
    assert sorted(order) == list(range(len(points))) and not np.array_equal(order, np.arange(len(points)))


def test_spread_bits_puts_bit_k_at_bit_3k():
    x = np.array([0, 1, 2, 3, 0b1011, 2 ** 21 - 1], dtype=np.uint64)
    expected = [sum(((int(v) >> k) & 1) << (3 * k) for k in range(21)) for v in x]
    assert [int(v) for v in _spread_bits(x)] == expected
