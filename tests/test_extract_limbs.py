"""``--template auto``: which branches are limbs, how stable the skeleton is when the mesh is written differently,
and how far its confidence trusts it (``autorig.extract.paths``, ``skeleton``, ``voxels``, ``confidence``).

Small shapes and low voxel resolutions keep these fast; the shared meshes are in ``test_extract.py``.
"""
from __future__ import annotations

import numpy as np
import pytest

import autorig
from autorig.extract import AUTO, voxelize
from autorig.extract.confidence import MARGIN_FULL, decision_margin, skeleton_symmetry
from autorig.extract.connect import VoxelGraph
from autorig.extract.paths import LIMB_SHARE, Candidate, extreme_points
from autorig.extract.shapes import CreatureSpec, LimbSpec, creature, score_limbs, star
from autorig.extract.skeleton import soft_split


def rewritten(vertices, faces):
    """(label, vertices, faces, scale) of the same mesh written differently."""
    height = float(np.ptp(vertices[:, 1]))
    for seed in (0, 1):
        yield f"noise{seed}", vertices + np.random.default_rng(seed).uniform(-1e-6, 1e-6, vertices.shape) * height, \
            faces, 1.0
    order = np.random.default_rng(0).permutation(len(vertices))
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order))
    yield "vertex order", vertices[order], inverse[faces], 1.0
    yield "corners", vertices, faces[:, [1, 2, 0]], 1.0
    yield "x0.01", vertices * 0.01, faces, 0.01
    yield "x100", vertices * 100.0, faces, 100.0


def test_rewritten_mesh_gives_the_same_skeleton():
    """Noise of a millionth of the height, another vertex order, rotated corners, other units: the same chains
    and no joint moving more than 0.5 % of the height."""
    shape = star(arms=4)
    options = autorig.RigOptions(voxels=40)
    plain = autorig.rig((shape.vertices, shape.faces), AUTO, options)
    height = float(np.ptp(shape.vertices[:, 1]))
    for label, vertices, faces, scale in rewritten(shape.vertices, shape.faces):
        rig = autorig.rig((vertices, faces), AUTO, options)
        assert rig.names == plain.names, label
        moved = np.linalg.norm(rig.joints / scale - plain.joints, axis=1).max()
        assert moved <= 0.005 * height, (label, moved / height)


def test_mirror_twins_are_taken_left_first():
    """Two extreme points as far from the heart, one each side: the left one (+x) first, whatever their node
    numbers, and still when the right one is a little farther (the voxels' noise between mirror twins)."""
    voxels = np.array([[x, 0, 0] for x in range(11)], dtype=np.int64)       # node i at x = i; heart at 5
    edges = np.array([[i, i + 1] for i in range(10)], dtype=np.int64)
    graph = VoxelGraph(voxels, np.ones(11), edges, np.ones(10))
    geodesic = np.abs(np.arange(11.0) - 5.0)
    assert list(extreme_points(graph, geodesic)) == [10, 0]
    geodesic[0] += 0.05                                                     # the right one a little farther
    assert list(extreme_points(graph, geodesic)) == [10, 0]
    geodesic[0] += 5.0                                                      # much farther: it goes first
    assert list(extreme_points(graph, geodesic)) == [0, 10]


def test_soft_split_moves_little_when_the_path_moves_little():
    """On a gentle arc every split point fits almost as well: the joint sits between them, and a path moved by
    a hundredth of a voxel moves it by about as much, not to another point of the path."""
    t = np.linspace(0.0, 1.0, 41)
    arc = np.stack([30 * t, 2.0 * np.sin(np.pi * t), np.zeros_like(t)], axis=1)
    joint = soft_split(arc, 0, 40)
    assert abs(joint[0] - 15.0) < 1.0                                       # the middle of a symmetric arc
    nudged = arc + np.random.default_rng(0).uniform(-0.01, 0.01, arc.shape)
    assert np.linalg.norm(soft_split(nudged, 0, 40) - joint) < 0.1
    # An L bends sharply at one point: the joint is there.
    ell = np.concatenate([np.stack([np.arange(20.0), np.zeros(20), np.zeros(20)], axis=1),
                          np.stack([np.full(11, 20.0), np.arange(11.0), np.zeros(11)], axis=1)])
    np.testing.assert_allclose(soft_split(ell, 0, 30), [20.0, 0.0, 0.0], atol=0.05)
    assert soft_split(ell, 0, 30, min_bone=25.0) is None


def test_voxel_grid_has_a_voxel_at_the_middle_of_the_mesh():
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 0.6, 0.3))
    vertices, faces = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    grid = voxelize(vertices, faces, 24)
    assert all(n % 2 == 1 for n in grid.inside.shape)
    middle = grid.origin + grid.step * (np.array(grid.inside.shape) - 1) / 2
    np.testing.assert_allclose(middle, 0.0, atol=1e-12)
    # Moved by less than a cell, the lattice moves with it: every inside voxel the same.
    moved = voxelize(vertices + 1e-7, faces, 24)
    np.testing.assert_array_equal(moved.inside, grid.inside)
    np.testing.assert_allclose(moved.origin - grid.origin, 1e-7, atol=1e-12)


def test_blob_bumps_get_no_chain():
    """A lumpy body with two limbs: a chain per limb, none for the six bumps (each as thick as it is long)."""
    def limb(direction, length):
        d = np.asarray(direction, dtype=float)
        return LimbSpec(tuple(d / np.linalg.norm(d)), length, 3.0, 0.8, 0.0, (0.0, 0.0, 1.0), 0.5)

    bumps = ((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.6, 0.6, 0.5), (-0.6, 0.6, -0.5))
    spec = CreatureSpec("blob", (1.3, 0.9, 0.8), (0.0, 0.0, 0.0), bumps,
                        (limb((1.0, -0.2, 0.0), 1.2), limb((-1.0, -0.2, 0.1), 1.0)), True)
    shape = creature(spec)
    rig = autorig.rig((shape.vertices, shape.faces), AUTO, autorig.RigOptions(up="y", front="z"))
    score = score_limbs(shape, rig.names, rig.parents, rig.joints)
    assert score.exact, (score.limbs, score.chains, score.found)
    assert rig.info["confidence"] > 0.5


def test_decision_margin_is_low_on_a_near_tie():
    def tried(share, ripple=False):
        return Candidate(0, 10.0, share, ripple, share >= LIMB_SHARE and not ripple)

    sure, closest = decision_margin([tried(0.9), tried(0.5 * LIMB_SHARE)])
    assert sure == 1.0 and closest == pytest.approx(0.5 * LIMB_SHARE)
    near = MARGIN_FULL ** 0.1                                   # a tenth of the way (in ratio) to a sure call
    assert decision_margin([tried(0.9), tried(near * LIMB_SHARE)])[0] == pytest.approx(0.1, abs=0.01)
    assert decision_margin([tried(0.9), tried(LIMB_SHARE / near)])[0] == pytest.approx(0.1, abs=0.01)
    # Half way (in ratio) to a sure call scores about half.
    assert decision_margin([tried(LIMB_SHARE * MARGIN_FULL ** 0.5)])[0] == pytest.approx(0.5, abs=0.01)
    # A ripple decides nothing; with nothing decided the part is 1.
    assert decision_margin([tried(1.01 * LIMB_SHARE, ripple=True)]) == (1.0, 0.0)


def test_symmetry_part_penalises_a_lopsided_skeleton_of_a_symmetric_mesh():
    import trimesh

    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    V, F = np.asarray(ball.vertices), np.asarray(ball.faces, dtype=np.int64)
    parents = np.array([-1, 0, 0])
    twins = np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.0], [-0.3, 0.2, 0.0]])
    lopsided = np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.0], [0.3, -0.2, 0.0]])
    part, mesh, ends = skeleton_symmetry(V, F, twins, parents)
    assert mesh > 0.95 and ends > 0.95 and part > 0.95
    part, mesh, ends = skeleton_symmetry(V, F, lopsided, parents)
    assert ends < 0.05 and part < 0.1
    # A lopsided mesh costs nothing, whatever its skeleton.
    knob = trimesh.creation.box(extents=(0.6, 0.2, 0.2))
    knob.apply_translation([0.6, 0.0, 0.0])
    both = trimesh.util.concatenate([ball, knob])
    part, mesh, _ = skeleton_symmetry(np.asarray(both.vertices), np.asarray(both.faces, dtype=np.int64), lopsided,
                                      parents)
    assert mesh < 0.9 and part > 0.9
