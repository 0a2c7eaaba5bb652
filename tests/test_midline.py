"""Mid-plane joints read their side-to-side coordinate off the body's chord (autorig.readoff.midline)."""
from pathlib import Path

import numpy as np
import pytest

import autorig
from autorig.readoff.midline import chord_middle


def test_the_middle_of_a_symmetric_chord_is_its_centre_wherever_the_point_lies_on_it():
    depth = lambda p: 0.3 - np.abs(p[:, 0] - 0.2)          # noqa: E731 - inside for 0.2 +- 0.3
    for x in (0.0, 0.15, 0.45):
        assert abs(chord_middle(depth, np.array([x, 0.0, 0.0]), -2, 2) - 0.2) < 1e-3


def test_a_thin_part_joined_at_one_side_pulls_the_middle_little_and_a_point_outside_is_left_alone():
    trunk = lambda p: 0.3 - np.abs(p[:, 0])                  # noqa: E731
    with_arm = lambda p: np.maximum(trunk(p), np.minimum(0.02, 0.8 - np.abs(p[:, 0] - 0.5)))   # noqa: E731
    assert abs(chord_middle(with_arm, np.array([0.05, 0, 0]), -2, 2)) < 0.02
    assert chord_middle(trunk, np.array([0.9, 0, 0]), -2, 2) is None


def test_a_joint_near_the_surface_is_centred_the_less_the_nearer_it_lies_never_at_a_switch():
    """A mid-plane joint pulled to the skin was centred or not as a rounding error fell (a seated body's head:
    3 % of the height to one side). Now: at the surface it stays; from ``FULL_DEPTH`` of the height deep (or as
    deep as its way to the chord's middle is long) it goes all the way, however far off the middle it lies (a
    flattened trunk's joint); in between, a hair deeper moves it by a small multiple of a hair."""
    from autorig.readoff.midline import FULL_DEPTH, SAMPLES, centred
    from autorig.template import load_template

    template = load_template("biped")
    head = template.names.index("head")
    vertices = np.array([[-0.1, 0.0, 0.0], [0.5, 1.0, 0.0]])       # the box: x in [-0.1, 0.5], height 1
    depth = lambda p: 0.3 - np.abs(p[:, 0] - 0.2)                    # noqa: E731 - chord middle at x = 0.2
    step = (0.6 + 2 * 0.02 * 0.6) / (SAMPLES - 1)

    def head_x(d):
        """The head's x after centring, placed at depth ``d`` on the chord's right half (0.3 - d from its
        middle)."""
        joints = np.array(template.positions, float)
        joints[head] = [0.5 - d, 0.8, 0.0]
        return centred(joints, template, depth, vertices)[head, 0]

    assert head_x(0.5 * step) == 0.5 - 0.5 * step                    # at the surface: left where it is
    assert abs(head_x(step + FULL_DEPTH) - 0.2) < 1e-6               # 0.28 off the middle, FULL_DEPTH deep
    xs = [head_x(d) for d in np.linspace(0.5 * step, step + FULL_DEPTH, 41)]
    assert all(a >= b for a, b in zip(xs, xs[1:]))                   # the deeper, the nearer the middle
    for d in np.linspace(0.5 * step, step + FULL_DEPTH, 17):
        assert abs(head_x(d + 1e-6) - head_x(d)) < 1e-4, d          # the switch jumped by 0.28


def test_a_symmetric_body_gets_its_mid_plane_joints_on_its_mid_plane_under_noise():
    from autorig.samples import mannequin
    sample = mannequin("a", resolution=64)
    height = float(np.ptp(sample.vertices[:, 1]))
    centre = (sample.vertices[:, 0].min() + sample.vertices[:, 0].max()) / 2
    options = autorig.RigOptions(up="y", front="z")
    rig = autorig.rig((sample.vertices, sample.faces), options=options)
    noise = np.random.default_rng(3).uniform(-1e-6, 1e-6, sample.vertices.shape) * height
    moved = autorig.rig((sample.vertices + noise, sample.faces), options=options)
    for name in ("hips", "spine", "chest", "neck", "head"):
        assert abs(rig.joint(name)[0] - centre) < 0.002 * height, name
        assert abs(moved.joint(name)[0] - rig.joint(name)[0]) < 0.001 * height, name


RHINO = Path(__file__).resolve().parents[2] / "shared" / "data" / "train" / "0ad_rhino" / "mesh.obj"


@pytest.mark.skipif(not RHINO.exists(), reason="shared data (../shared/data) is not present")
def test_a_symmetric_bodys_spheres_do_not_change_when_its_floats_do():
    """The octree's centre plane is a symmetric body's mid-plane: its corners' left/right ties must not decide
    the medial samples (autorig.discretize.medial._off_the_centre_planes). The 0 A.D. rhino's packing moved
    184 -> 178 spheres under this noise, and its tail's end to its horn."""
    from autorig.input.mesh import load_mesh, prepare
    from autorig.pipeline import discretize
    vertices, faces = load_mesh(RHINO)
    height = float(np.ptp(vertices[:, 1]))
    graphs = []
    for seed in (None, 0):
        noise = 0 if seed is None else np.random.default_rng(seed).uniform(-1e-6, 1e-6, vertices.shape)
        graphs.append(discretize(prepare(vertices + noise * height, faces, "y", "z", checked=True))[1])
    from scipy.spatial import cKDTree
    assert len(graphs[1].radii) == len(graphs[0].radii)
    moved = cKDTree(graphs[0].centers).query(graphs[1].centers)[0]   # each sphere's nearest, in any order
    assert np.mean(moved < 1e-4) > 0.9 and moved.max() < 0.05    # was 184 -> 178 spheres


def test_the_centre_planes_nudged_corners_are_queried_once_and_read_as_one_at_a_time():
    """medial._NudgedNearest asks the surface once per (corner, nudge) for all the plane sides together (about a
    quarter of the queries at 86k faces): each edge end still gets the nearest point of its own nudged point,
    to the bit, as when each end was queried by itself."""
    from autorig.discretize import medial
    from autorig.discretize.distance import distance_field
    from autorig.input.mesh import prepare
    from autorig.samples import mannequin
    sample = mannequin("a", resolution=48)
    prepared = prepare(sample.vertices, sample.faces, "y", "z")
    field = distance_field(prepared.work_vertices, prepared.work_faces, max_level=6)
    centre = 2 ** (field.max_level - 1)
    # Every edge of the finest grid that touches a centre plane, near the body's middle, along each axis.
    grid = np.stack(np.meshgrid(*[np.arange(centre - 3, centre + 3)] * 3, indexing="ij"), -1).reshape(-1, 3)
    grid = grid[(grid == centre).any(axis=1)]
    a_idx = np.repeat(grid, 3, axis=0)
    axis = np.tile(np.arange(3), len(grid))
    b_idx = a_idx.copy()
    b_idx[np.arange(len(axis)), axis] += 1
    a, b = field.origin + a_idx * field.finest, field.origin + b_idx * field.finest
    ca, cb = field.surface.nearest(a), field.surface.nearest(b)
    sides = list(medial._plane_sides(field, a_idx, axis))
    assert len(sides) == 7                                 # an edge lies in two planes at most
    requests = [medial._nudges(field, idx[rows], axis[rows], end, signs)
                for signs, rows in sides for idx, end in ((a_idx, -1.0), (b_idx, 1.0))]
    nudged = medial._NudgedNearest(field, requests)
    asked = sum(int(np.any(n != 0, axis=1).sum()) for _, n in requests)
    assert len(nudged.keys) < asked / 2                   # the same nudged points, asked for by many edges
    for signs, rows in sides:
        got = medial._off_the_centre_planes(field, a_idx[rows], b_idx[rows], axis[rows], a[rows], b[rows],
                                            ca[rows], cb[rows], signs, nudged)
        for ends, idx, near, end, out in ((a, a_idx, ca, -1.0, got[0]), (b, b_idx, cb, 1.0, got[1])):
            on = idx[rows] == centre
            nudge = np.where(on, signs[None, :], 0.0)
            nudge[np.arange(len(rows)), axis[rows]] = np.where(on[np.arange(len(rows)), axis[rows]], end, 0.0)
            moved = np.any(nudge != 0, axis=1)
            expected = near[rows].copy()
            expected[moved] = field.surface.closest(ends[rows][moved] + nudge[moved] * medial.NUDGE
                                                    * field.finest)[1]
            assert np.array_equal(out, expected)
            assert moved.any() and not np.array_equal(out[moved], near[rows][moved])
