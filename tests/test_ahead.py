"""autorig.weights.ahead: work begun in a forked child gives the caller exactly what it would have computed."""
import os
import sys

import numpy as np
import pytest

from autorig.weights import ahead, attach
from autorig.weights.ahead import Ahead
from autorig.pipeline import rig
from autorig.samples import mannequin

forks = pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                           reason="forks on Linux with 2 CPUs only")


def _children() -> set[int]:
    try:
        return {int(p) for p in open(f"/proc/{os.getpid()}/task/{os.getpid()}/children").read().split()}
    except OSError:
        return set()


@forks
def test_value_comes_from_the_child_for_the_same_arguments_only():
    data = np.arange(12.0).reshape(4, 3)
    done = Ahead(lambda a: (os.getpid(), a * 2), (data,))
    pid, value = done.result_if(data)
    assert pid != os.getpid()               # made in the child
    assert np.array_equal(value, data * 2)
    assert done.result_if(data) is None     # read once
    replaced = Ahead(lambda a: a * 2, (data,))
    assert replaced.result_if(data.copy()) is None   # other objects: the caller computes afresh


@forks
def test_a_dropped_or_unwanted_handle_leaves_no_child():
    before = _children()
    Ahead(lambda: (__import__("time").sleep(30), 1), ())   # dropped unread: stopped, not waited 30 s for
    assert _children() == before
    assert Ahead(lambda: 1, (), wanted=False).result_if() is None


def test_dense_mesh_rigs_the_same_with_and_without_the_child(monkeypatch):
    sample = mannequin(pose="a", resolution=48)
    # A heat surface this small makes the mannequin "dense": its simplified copy is what the child makes.
    monkeypatch.setattr(attach, "HEAT_MAX_VERTICES", len(sample.vertices) // 3)
    results = []
    for enabled in (True, False):
        monkeypatch.setattr(ahead, "ENABLED", enabled)
        results.append(rig((sample.vertices, sample.faces)))
    # Equal to rounding: when the orientation moves the body to its mid-plane, the simplified copy made before
    # moves along instead of being made again.
    assert np.array_equal(results[0].joints, results[1].joints)
    assert np.allclose(results[0].weights, results[1].weights, atol=1e-8)
    assert np.array_equal(results[0].weights.argmax(axis=1), results[1].weights.argmax(axis=1))


@forks
def test_heat_surface_made_ahead_follows_the_mesh_to_its_mid_plane(monkeypatch):
    from autorig.weights.attach import heat_surface, start_heat_surface
    from autorig.input.mesh import prepare
    sample = mannequin(pose="a", resolution=48)
    monkeypatch.setattr(attach, "HEAT_MAX_VERTICES", len(sample.vertices) // 3)   # dense: simplified, forked
    prepared = prepare(sample.vertices, sample.faces)
    ahead_of = start_heat_surface(prepared)
    moved = prepared.centred_at(0.0123)                     # what the orientation does to a lopsided body
    weld, Vw, Fw, coarse, (K, mass) = ahead_of.result_for(moved)
    weld2, Vw2, Fw2, coarse2, (K2, mass2) = heat_surface(moved.vertices, moved.faces)
    assert np.array_equal(weld, weld2) and np.array_equal(Vw, Vw2) and np.array_equal(Fw, Fw2)
    assert np.allclose(coarse[0], coarse2[0], atol=1e-9) and np.array_equal(coarse[1], coarse2[1])
    # Where each vertex lands on the copy (a vertex on an edge may take either face: the same point).
    lands, lands2 = (np.einsum("nk,nkd->nd", c[3], c[0][c[2]]) for c in (coarse, coarse2))
    assert np.allclose(lands, lands2, atol=1e-9)
    assert np.allclose(K.toarray(), K2.toarray(), atol=1e-6) and np.allclose(mass, mass2, atol=1e-12)
    turned = prepared.reframed("z", "-y")                   # other axes: made afresh, not taken from the child
    assert start_heat_surface(prepared).result_for(turned) is None


def _with_slivers(vertices, faces, count=20):
    """The mesh with ``count`` of its triangles each split in two at a point 1e-4 of an edge from a corner: the
    smaller piece has an angle of well under a degree (a sliver), the surface is the same."""
    V, F = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    picked = np.linspace(0, len(F) - 1, count).astype(np.int64)
    a, b, c = F[picked].T
    new = np.arange(len(V), len(V) + count)
    V = np.vstack([V, V[a] + 1e-4 * (V[b] - V[a])])
    F = np.vstack([np.delete(F, picked, axis=0), np.stack([a, new, c], axis=1), np.stack([new, b, c], axis=1)])
    return V, F


@forks
def test_a_small_mesh_with_slivers_makes_its_heat_surface_ahead_and_rigs_the_same(monkeypatch):
    from autorig.weights.attach import COT_LIMIT, face_cotangents, start_heat_surface
    from autorig.input.mesh import prepare
    sample = mannequin(pose="a", resolution=48)
    V, F = _with_slivers(sample.vertices, sample.faces)
    assert not np.all(np.abs(face_cotangents(V, F)) <= COT_LIMIT)   # the robust Laplacian's case
    assert len(V) < attach.HEAT_MAX_VERTICES                        # not dense: only the slivers call for it
    before = _children()
    prepared = prepare(V, F)
    started = start_heat_surface(prepared)
    assert len(_children() - before) == 1
    assert started.result_for(prepared.reframed("z", "-y")) is None   # another frame: the child is stopped
    assert _children() == before
    start_heat_surface(prepare(sample.vertices, sample.faces))       # no slivers, not dense: no fork
    assert _children() == before
    results = []
    for enabled in (True, False):
        monkeypatch.setattr(ahead, "ENABLED", enabled)
        results.append(rig((V, F)))
    # Equal to rounding: a body the orientation moves to its mid-plane keeps the Laplacian made before the move.
    assert np.array_equal(results[0].joints, results[1].joints)
    assert np.allclose(results[0].weights, results[1].weights, atol=1e-8)
    assert np.array_equal(results[0].weights.argmax(axis=1), results[1].weights.argmax(axis=1))
