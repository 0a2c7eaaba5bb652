"""Bone-heat skin weights (autorig.weights.attach.bone_heat) on small synthetic meshes."""
import numpy as np
import pytest
import trimesh

from autorig.weights.attach import bone_heat, segment_distances


def _box(extents, center, max_edge):
    """A box mesh subdivided so that its faces have interior vertices: (vertices [V, 3], faces [F, 3])."""
    box = trimesh.creation.box(extents=extents)
    V, F = trimesh.remesh.subdivide_to_size(box.vertices, box.faces, max_edge=max_edge)
    return np.asarray(V) + center, np.asarray(F, np.int64)


def _concat(*parts):
    """One mesh soup from several (vertices, faces) parts, in order."""
    Vs, Fs, n = [], [], 0
    for V, F in parts:
        Vs.append(V)
        Fs.append(F + n)
        n += len(V)
    return np.vstack(Vs), np.vstack(Fs)


def _check_rows(W, n_vertices, n_joints):
    assert W.shape == (n_vertices, n_joints)
    assert np.isfinite(W).all()
    assert (W >= 0).all()
    np.testing.assert_allclose(W.sum(axis=1), 1.0, atol=1e-9)


@pytest.fixture(scope='module')
def cylinder():
    """A closed cylinder of radius 0.25 along y from -1 to 1, finely tessellated, and its weights for a
    3-joint chain along the axis (joint 0 at y=-0.9, joint 1 at y=0, tip joint 2 at y=0.9)."""
    mesh = trimesh.creation.cylinder(radius=0.25, height=2.0, sections=24)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))   # z axis -> y axis
    V, F = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=0.08)
    V, F = np.asarray(V), np.asarray(F, np.int64)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    return V, F, bone_heat(V, F, joints, np.array([-1, 0, 1]))


def test_cylinder_rows_are_partitions_of_unity(cylinder):
    V, F, W = cylinder
    _check_rows(W, len(V), 3)


def test_cylinder_ends_follow_their_bone_and_tip_is_empty(cylinder):
    V, F, W = cylinder
    y = V[:, 1]
    assert (W[y < -0.6, 0] > 0.95).all()
    assert (W[y > 0.6, 1] > 0.95).all()
    assert (W[:, 2] == 0).all()                   # the tip owns no bone


def test_cylinder_weights_vary_monotonically_along_axis(cylinder):
    V, F, W = cylinder
    side = np.abs(np.linalg.norm(V[:, [0, 2]], axis=1) - 0.25) < 1e-6
    y, w = V[side, 1], W[side, 1]
    levels = np.unique(np.round(y, 6))
    mean = np.array([w[np.round(y, 6) == level].mean() for level in levels])
    assert np.all(np.diff(mean) >= -1e-6)
    assert mean[0] < 0.05 and mean[-1] > 0.95
    # and around each ring the weight hardly changes: the heat is axially symmetric
    spread = np.array([np.ptp(w[np.round(y, 6) == level]) for level in levels])
    assert spread.max() < 0.05


def test_part_without_bones_takes_nearest_bone():
    body = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.2)
    far = _box([0.5, 0.5, 0.5], [0, 6.0, 0], 0.2)        # far above the chain's upper end, no bone inside
    V, F = _concat(body, far)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    _check_rows(W, len(V), 3)
    far_rows = W[len(body[0]):]
    np.testing.assert_allclose(far_rows[:, 1], 1.0, atol=1e-9)   # upper bone (1 -> 2), owned by joint 1


def test_part_beside_the_chain_follows_the_nearest_bones():
    body = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.2)
    side = _box([0.3, 0.3, 0.3], [3.0, -0.7, 0], 0.1)     # a separate part level with the lower bone
    V, F = _concat(body, side)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    _check_rows(W, len(V), 3)
    assert (W[len(body[0]):, 0] > 0.99).all()


def test_duplicates_degenerate_faces_and_loose_vertices():
    V, F = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.25)
    n = len(V)
    # split the mesh along a seam: the faces on the +x side use copies of their vertices
    plus = np.flatnonzero(V[:, 0] > 0.2)
    copy = np.full(n, -1)
    copy[plus] = n + np.arange(len(plus))
    V = np.vstack([V, V[plus]])
    right = V[F].mean(axis=1)[:, 0] > 0.2
    F = F.copy()
    F[right] = np.where(copy[F[right]] >= 0, copy[F[right]], F[right])
    # a zero-area face (an edge's midpoint), a face with a repeated corner and a vertex on no face
    a, b = F[0, 0], F[0, 1]
    V = np.vstack([V, (V[a] + V[b]) / 2, [[0.0, 5.0, 0.0]]])
    mid, loose = len(V) - 2, len(V) - 1
    F = np.vstack([F, [[a, mid, b], [a, a, b]]])
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    _check_rows(W, len(V), 3)
    np.testing.assert_allclose(W[plus], W[n:n + len(plus)])    # coincident vertices share their weights
    assert W[loose, 1] > 0.99                                  # the loose vertex follows the closest surface


@pytest.mark.parametrize('scale', [1.0, 1e-3])
def test_visibility_keeps_legs_apart(scale):
    # Two legs hanging from a bar, 0.2 apart: a wide left leg with its bone near its outer side and a thin
    # right leg. The inner side of the left leg is closer to the right leg's bone than to its own, but cannot
    # see it through the right leg's surface. At a millimetre scale too (ray tests with absolute epsilons
    # miss every hit on small triangles there).
    left = _box([2.0, 3.0, 1.0], [-1.1, 1.5, 0], 0.2)           # x in [-2.1, -0.1]
    right = _box([0.4, 3.0, 1.0], [0.3, 1.5, 0], 0.2)           # x in [0.1, 0.5]
    bar = _box([2.6, 0.6, 1.0], [-0.8, 3.2, 0], 0.2)           # overlaps the legs' tops
    V, F = _concat(left, right, bar)
    joints = np.array([[-0.8, 3.2, 0],                           # 0 root, in the bar
                       [-1.9, 2.8, 0], [-1.9, 0.2, 0],           # 1, 2: left leg
                       [0.3, 2.8, 0], [0.3, 0.2, 0]])            # 3, 4: right leg
    parents = np.array([-1, 0, 1, 0, 3])
    W = bone_heat(V * scale, F, joints * scale, parents)
    _check_rows(W, len(V), 5)
    index = np.arange(len(V))
    in_left = index < len(left[0])
    in_right = (index >= len(left[0])) & (index < len(left[0]) + len(right[0]))
    low = V[:, 1] < 2.5                                          # below the bar
    # the test means something only if the right bone is the Euclidean-nearest for many left-leg vertices
    d = segment_distances(V, joints[parents[[2, 4]]], joints[[2, 4]])
    fooled = in_left & low & (d[:, 1] < d[:, 0])
    assert fooled.sum() >= 20
    assert W[in_left & low, 3].max() < 0.01                      # nothing of the left leg follows the right leg
    assert (W[fooled][:, [0, 1]].sum(axis=1) > 0.99).all()        # they follow their own leg (and the root)
    assert W[in_right & low, 1].max() < 0.01
    assert (W[in_right & (V[:, 1] < 2.0), 3] > 0.9).all()


def test_owners_and_single_joint():
    V, F = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.25)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    # each bone owned by its child joint instead of its parent
    Wc = bone_heat(V, F, joints, np.array([-1, 0, 1]), owners=np.array([-1, 1, 2]))
    np.testing.assert_allclose(Wc[:, 1:], W[:, :2])
    assert (Wc[:, 0] == 0).all()
    W1 = bone_heat(V, F, joints[:1], np.array([-1]))
    np.testing.assert_array_equal(W1, np.ones((len(V), 1)))


def test_invariant_to_scale_and_translation():
    V, F = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.2)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    for scale, shift in [(1e-4, 3.0), (1e4, -7.0)]:
        Ws = bone_heat(V * scale + shift, F, joints * scale + shift, np.array([-1, 0, 1]))
        np.testing.assert_allclose(Ws, W, atol=1e-6)


def test_deterministic_and_input_order_kept():
    V, F = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.25)
    joints = np.array([[0, -0.9, 0], [0, 0.0, 0], [0, 0.9, 0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]))
    perm = np.random.default_rng(0).permutation(len(V))
    inverse = np.argsort(perm)
    Wp = bone_heat(V[perm], inverse[F], joints, np.array([-1, 0, 1]))
    np.testing.assert_allclose(Wp, W[perm], atol=1e-9)
    np.testing.assert_array_equal(bone_heat(V, F, joints, np.array([-1, 0, 1])), W)


def test_rejects_bad_skeleton():
    V, F = _box([0.5, 2.0, 0.5], [0, 0, 0], 0.5)
    with pytest.raises(ValueError):
        bone_heat(V, F, np.zeros((2, 3)), np.array([1, -1]))      # child before its parent
    with pytest.raises(ValueError):
        bone_heat(V, F + len(V), np.zeros((2, 3)), np.array([-1, 0]))


def test_a_dense_surface_lies_on_its_own_parts_simplified_copy(monkeypatch):
    """A lens half sunk into a dense sphere (an eye, a nail): solved on a simplified copy, every sphere vertex
    takes its heat from the sphere's copy and every lens vertex from the lens's, though the copy's lens is
    the closest copy triangle to some of the sphere's vertices under it (5 of them before, and 10 the other
    way)."""
    from scipy.sparse.csgraph import connected_components
    import scipy.sparse as sp

    from autorig.weights import attach

    body = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    lens = trimesh.creation.icosphere(subdivisions=3, radius=0.15)
    lens_v = lens.vertices * [1, 1, 0.2] + [0, 0, 1.02]
    V = np.vstack([body.vertices, lens_v])
    F = np.vstack([body.faces, lens.faces + len(body.vertices)])
    monkeypatch.setattr(attach, "HEAT_MAX_VERTICES", 400)
    weld, Vw, Fw, coarse, _ = attach.heat_surface(V, F)
    coarse_V, coarse_F, corners, _ = coarse
    assert len(coarse_V) < len(Vw) / 4
    n = len(coarse_V)
    adj = sp.coo_matrix((np.ones(coarse_F.size), (coarse_F.ravel(), np.roll(coarse_F, 1, axis=1).ravel())),
                        shape=(n, n))
    _, part = connected_components(adj, directed=False)
    sphere_part = np.argmax(np.bincount(part[coarse_F.ravel()]))
    on_sphere = part[corners].max(axis=1) == sphere_part
    on_sphere_too = part[corners].min(axis=1) == sphere_part
    assert np.array_equal(on_sphere, on_sphere_too)                 # each triangle on one part
    assert on_sphere[weld[:len(body.vertices)]].all()
    assert not on_sphere[weld[len(body.vertices):]].any()
    # the lens, a tenth of the height or less, moves rigidly with the sphere under it, on the copy as on the
    # dense surface
    joints = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    W = bone_heat(V, F, joints, np.array([-1, 0, 1]), height=5.0)     # the lens: 0.43 across
    lens_rows = W[len(body.vertices):]
    assert np.ptp(lens_rows, axis=0).max() < 1e-9
    under = np.linalg.norm(body.vertices - [0, 0, 1], axis=1) < 0.15
    np.testing.assert_allclose(lens_rows[0], W[:len(body.vertices)][under].mean(axis=0), atol=0.05)
