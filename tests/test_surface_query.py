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


def _children() -> set[int]:
    import os
    try:
        return {int(p) for p in open(f"/proc/{os.getpid()}/task/{os.getpid()}/children").read().split()}
    except OSError:
        return set()


def _forks() -> bool:
    import os
    import sys
    return sys.platform.startswith("linux") and len(os.sched_getaffinity(0)) >= 2


def test_batches_shared_with_the_partner_answer_each_point_as_alone(monkeypatch):
    """Inside ``sharing()`` a large batch is answered half by a forked child: the same answers, to the bit, as
    this process gives alone, in the caller's order; the child is gone after the block, and a child that died
    leaves the batch to this process, answered the same."""
    import os
    import signal

    import pytest

    from autorig.discretize import partner as partner_module
    from autorig.samples import mannequin
    if not _forks():
        pytest.skip("forks on Linux with 2 CPUs only")
    monkeypatch.setattr(partner_module, "_idle_core", lambda: True)    # however busy the machine is
    sample = mannequin("a", resolution=40)
    surface = SurfaceQuery(sample.vertices, sample.faces)
    rng = np.random.default_rng(1)
    lo, hi = sample.vertices.min(axis=0), sample.vertices.max(axis=0)
    points = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (3 * partner_module.PARTNER_MIN + 1, 3))
    alone = surface.closest_on(points), surface.winding(points)
    before = _children()
    with surface.sharing() as partner:
        assert partner.alive and surface.partner is partner and len(_children() - before) == 1
        shared = surface.closest_on(points), surface.winding(points)
        os.kill(partner._pid, signal.SIGKILL)        # the child dies: this process answers it all
        orphaned = surface.closest_on(points), surface.winding(points)
        assert not partner.alive
    assert surface.partner is None and _children() == before
    for other in (shared, orphaned):
        for a, b in zip((*alone[0], alone[1]), (*other[0], other[1])):
            assert a.dtype == b.dtype and np.array_equal(a, b)


def test_the_field_is_the_same_with_the_partner_and_without_the_centres_its_corners_decide(monkeypatch):
    """The distance field built with the partner (or without it), and skipping the centres of cells that its
    corners already keep as leaves, has the leaves and values of the field that asks for every centre in this
    process alone: the same to the bit, and no point evaluated that the full field did not evaluate too."""
    from autorig.discretize import distance
    from autorig.discretize import partner as partner_module
    from autorig.input.mesh import prepare
    from autorig.samples import mannequin
    from autorig.weights import ahead
    sample = mannequin("a", resolution=48)
    V, F = prepare(sample.vertices, sample.faces).coarse()
    monkeypatch.setattr(partner_module, "_idle_core", lambda: True)    # shared wherever the machine can fork
    built = {}
    for name, enabled, skip in (("shared", True, True), ("alone", False, True), ("every centre", False, False)):
        monkeypatch.setattr(ahead, "ENABLED", enabled)
        if not skip:
            monkeypatch.setattr(distance, "_certain_leaves", lambda centre, *rest: np.zeros(len(centre), bool))
        built[name] = distance.distance_field(V, F)
    full = built["every centre"]
    assert len(built["alone"].corner_depth) < 0.95 * len(full.corner_depth)   # the skip saves queries
    for name in ("shared", "alone"):
        field = built[name]
        for key in ("leaf_level", "leaf_index", "leaf_values"):
            assert np.array_equal(getattr(field, key), getattr(full, key)), (name, key)
        have = np.flatnonzero(field.corner_row >= 0)
        assert np.all(full.corner_row[have] >= 0)
        mine, theirs = field.corner_row[have], full.corner_row[have]
        assert np.array_equal(field.corner_depth[mine], full.corner_depth[theirs])
        assert np.array_equal(field.corner_nearest[mine], full.corner_nearest[theirs])
        assert np.array_equal(field.corner_face[mine], full.corner_face[theirs])


def test_no_partner_while_the_cores_are_busy_or_forks_are_off(monkeypatch):
    """The partner is only started while the load average leaves a core to spare and ``ahead.ENABLED`` is on
    (``autorig batch``'s workers turn it off); without it every batch is answered here, the same."""
    import os

    from autorig.discretize import partner as partner_module
    from autorig.samples import mannequin
    from autorig.weights import ahead
    surface = SurfaceQuery(*(lambda s: (s.vertices, s.faces))(mannequin("a", resolution=24)))
    before = _children()
    cpus = len(os.sched_getaffinity(0))
    monkeypatch.setattr(partner_module.os, "getloadavg", lambda: (float(cpus), 0.0, 0.0))
    assert not partner_module._idle_core()
    with surface.sharing() as busy:
        assert not busy.alive and _children() == before
    monkeypatch.setattr(partner_module.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert partner_module._idle_core() == (cpus >= 2)
    monkeypatch.setattr(ahead, "ENABLED", False)
    with surface.sharing() as off:
        assert not off.alive and _children() == before


def test_a_fork_that_fails_leaves_every_batch_here(monkeypatch):
    """No process to be had (a limit on processes or memory): no partner, no open pipes left, the same answers."""
    import os

    from autorig.discretize import partner as partner_module
    from autorig.samples import mannequin
    sample = mannequin("a", resolution=24)
    surface = SurfaceQuery(sample.vertices, sample.faces)
    points = np.random.default_rng(2).uniform(-0.5, 0.5, (partner_module.PARTNER_MIN + 5, 3)) + [0, 0.9, 0]
    alone = surface.distance(points)
    monkeypatch.setattr(partner_module, "_idle_core", lambda: True)

    def no_fork():
        raise BlockingIOError("Resource temporarily unavailable")
    monkeypatch.setattr(partner_module.os, "fork", no_fork)
    fds = len(os.listdir("/proc/self/fd")) if os.path.isdir("/proc/self/fd") else None
    with surface.sharing() as none:
        assert not none.alive
        assert np.array_equal(surface.distance(points), alone)
    if fds is not None:
        assert len(os.listdir("/proc/self/fd")) == fds
