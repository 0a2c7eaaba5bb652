"""Template-free skeletons (``autorig.rig(mesh, "auto")``, Wade & Parent 2002): one chain per limb, joints inside
the volume, and skin weights that move each limb with its own chain.

Low voxel resolutions keep these fast; the real meshes are read from ``../shared/data`` and skipped without it.
"""
from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import autorig
from autorig.extract import AUTO, fixed_axes
from autorig.extract.shapes import (CreatureSpec, LimbSpec, NumpyDraw, creature, random_creature, score_limbs, star,
                                    tree)
from autorig.extract.skeleton import best_split, split_chain
from autorig.input.mesh import load_mesh

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT.parent / "shared" / "data" / "meshes"
NAME = re.compile(r"root|chain[1-9][0-9]*_(joint[1-9][0-9]*|end)")


def shared_mesh(name: str):
    path = MESHES / f"{name}.obj"
    if not path.exists():
        pytest.skip(f"{path} not available")
    return load_mesh(path)


@cache
def rigged(kind: str, size: int, voxels: int = 48, up: str = "y", front: str = "z") -> autorig.Rig:
    """A rig of a test shape ("star", "tree": size = arms, levels) or a shared mesh (size ignored)."""
    if kind in ("star", "tree"):
        shape = star(arms=size) if kind == "star" else tree(levels=size)
        mesh = (shape.vertices, shape.faces)
    else:
        mesh = shared_mesh(kind)
    return autorig.rig(mesh, AUTO, autorig.RigOptions(up=up, front=front, voxels=voxels))


def chain_ends(rig) -> list[int]:
    return [j for j, name in enumerate(rig.names) if name.endswith("_end")]


def chain(name: str) -> str:
    return name.split("_")[0]


def winding(rig, points) -> np.ndarray:
    import igl
    return np.abs(igl.fast_winding_number(rig.vertices, rig.faces, np.asarray(points, dtype=np.float64)))


def nearest_ends(rig, points) -> list[str]:
    """Name of the chain end nearest to each of points [N, 3]."""
    ends = chain_ends(rig)
    distance = np.linalg.norm(rig.joints[ends][None] - np.asarray(points)[:, None], axis=2)
    return [rig.names[ends[k]] for k in distance.argmin(axis=1)]


def dominant(rig, point) -> str:
    """Name of the joint with the largest weight on the vertex nearest to point [3]."""
    i = int(np.argmin(np.linalg.norm(rig.vertices - point, axis=1)))
    return rig.names[int(np.argmax(rig.weights[i]))]


def moves_with(rig, point, end: str) -> bool:
    """Whether the vertex nearest to point [3] is dominated by a joint on the way from the root (excluded) out
    to the joint called end: it moves with that limb (a fingertip may follow its hand), never another."""
    way, j = [], rig.names.index(end)
    while j > 0:
        way.append(rig.names[j])
        j = rig.parents[j]
    return dominant(rig, point) in way


def posed(rig, joint: int, angle: float) -> np.ndarray:
    """The vertices [V, 3] with joint's subtree turned by angle (radians) about joint (linear blend skinning):
    a vertex moves by the share of its weight on the joints that turn."""
    turning = np.zeros(len(rig.names), dtype=bool)
    for j in range(len(rig.names)):              # parents come before children
        turning[j] = j == joint or (rig.parents[j] >= 0 and turning[rig.parents[j]])
    bone = rig.joints[joint] - rig.joints[rig.parents[joint]]
    axis = np.cross(bone, [0.3, 0.5, 0.8])
    axis /= np.linalg.norm(axis)
    rel = rig.vertices - rig.joints[joint]
    turned = (rel * np.cos(angle) + np.cross(axis, rel) * np.sin(angle)
              + np.outer(rel @ axis, axis) * (1 - np.cos(angle)))
    share = rig.weights[:, turning].sum(axis=1, keepdims=True)
    return rig.vertices + share * (turned - rel)


# ------------------------------------------------------------------------------------------------- shapes

@pytest.mark.parametrize("arms", [3, 5, 8])
def test_star_has_one_chain_per_arm(arms):
    rig = rigged("star", arms)
    shape = star(arms=arms)
    assert len(chain_ends(rig)) == arms
    # Each arm's tip has its own chain end, near it (within the cap's radius and a voxel or two).
    assert len(set(nearest_ends(rig, shape.tips))) == arms
    size = np.ptp(shape.vertices, axis=0).max()
    for tip, name in zip(shape.tips, nearest_ends(rig, shape.tips)):
        assert np.linalg.norm(rig.joint(name) - tip) < 0.06 * size


@pytest.mark.parametrize("levels", [2, 3])
def test_tree_has_one_chain_per_branch(levels):
    rig = rigged("tree", levels, voxels=64)           # at 48 voxels the finest twigs are a voxel thick
    shape = tree(levels=levels)
    assert len(shape.tips) == 2 ** levels + 1            # the twigs and the foot of the trunk
    assert len(chain_ends(rig)) == len(shape.tips)
    assert len(set(nearest_ends(rig, shape.tips))) == len(shape.tips)


def test_star_weights_move_each_arm_with_its_own_chain():
    rig = rigged("star", 5)
    shape = star(arms=5)
    size = np.ptp(shape.vertices, axis=0).max()
    tip_vertex = [int(np.argmin(np.linalg.norm(rig.vertices - t, axis=1))) for t in shape.tips]
    for arm, name in enumerate(nearest_ends(rig, shape.tips)):
        assert chain(dominant(rig, shape.tips[arm])) == chain(name)
        first = rig.names.index(f"{chain(name)}_joint1") if f"{chain(name)}_joint1" in rig.names \
            else rig.names.index(name)
        moved = np.linalg.norm(posed(rig, first, np.radians(30)) - rig.vertices, axis=1)
        own = moved[tip_vertex[arm]]
        others = np.delete(moved[tip_vertex], arm)
        assert own > 0.05 * size, (name, own)
        assert np.all(others < 0.01 * own), (name, others, own)


# ------------------------------------------------------------------------------------------------- creatures

def creature_rig(spec: CreatureSpec, max_segments: int = 8):
    """(shape, rig, score) of a creature rigged at the default voxels."""
    shape = creature(spec)
    rig = autorig.rig((shape.vertices, shape.faces), AUTO, autorig.RigOptions(up="y", front="z",
                                                                              max_segments=max_segments))
    return shape, rig, score_limbs(shape, rig.names, rig.parents, rig.joints)


def assert_rigger_would_draw(score) -> None:
    """One chain per limb; no knots; chains start where their limbs leave the body; straight limbs straight."""
    assert score.exact, (score.limbs, score.chains, score.found)
    assert score.shortest_bone >= 0.02
    assert np.all(score.start_gap < 8.0), score.start_gap          # voxels at the default resolution
    assert np.all(score.straight_inner <= 2), score.straight_inner


def limb(direction, length=1.6, radius=3.0, taper=1.0, bend=0.0, bend_axis=(0.0, 0.0, 1.0)) -> LimbSpec:
    d = np.asarray(direction, dtype=float)
    return LimbSpec(tuple(d / np.linalg.norm(d)), length, radius, taper, bend, bend_axis, 0.5)


@pytest.mark.parametrize("arms", [3, 7])
@pytest.mark.parametrize("welded", [True, False], ids=["welded", "overlapping"])
def test_ball_with_capsule_arms_has_a_chain_per_arm(arms, welded):
    from autorig.extract.shapes import _layout_directions

    limbs = tuple(limb(d) for d in _layout_directions(arms, "all round", 0.3))
    _, _, score = creature_rig(CreatureSpec("sphere", (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (), limbs, welded))
    assert_rigger_would_draw(score)


def ellipsoid_animal(welded: bool) -> CreatureSpec:
    """Four legs, a neck with a head, a thin tail on a long ellipsoid (+x forward, +y up)."""
    legs = tuple(limb((x, -1.0, z), length=1.4, radius=3.5, taper=0.6) for x in (0.8, -0.8) for z in (0.4, -0.4))
    neck = limb((1.0, 0.8, 0.0), length=1.2, radius=4.0, bend=50.0, bend_axis=(0.0, 0.0, -1.0))
    tail = limb((-1.0, 0.2, 0.0), length=1.5, radius=1.6)
    return CreatureSpec("ellipsoid", (1.7, 0.8, 0.7), (0.0, 0.0, 0.0), (), legs + (neck, tail), welded)


@pytest.mark.parametrize("welded", [True, False], ids=["welded", "overlapping"])
def test_ellipsoid_animal_has_a_chain_per_limb_and_no_knots(welded):
    shape, rig, score = creature_rig(ellipsoid_animal(welded))
    assert_rigger_would_draw(score)
    # The legs bend nowhere: each is its base and its tip, hanging from the root.
    legs = nearest_ends(rig, shape.tips[:4])
    for end in legs:
        joints = [n for n in rig.names if chain(n) == chain(end)]
        assert len(joints) <= 3, joints


def test_max_segments_still_bounds_each_chain():
    for budget in (1, 2):
        _, rig, score = creature_rig(ellipsoid_animal(True), max_segments=budget)
        assert score.found == score.limbs == score.chains
        for end in chain_ends(rig):
            assert len([n for n in rig.names if chain(n) == chain(rig.names[end])]) <= budget


# Seeds of numpy-drawn creatures (``benchmarks/extract_stages.py``) that once came out wrong: a bump on a flat
# blob made a chain (171).
@pytest.mark.parametrize("seed", [171])
def test_regression_creatures(seed):
    _, _, score = creature_rig(random_creature(NumpyDraw(np.random.default_rng(seed))))
    assert_rigger_would_draw(score)


# A fixed sample of the benchmark's creatures (``benchmarks/extract_stages.py`` draws 200 from numpy seeds). It was
# drawn by hypothesis, whose sample, derandomized, still depends on the numbers written in every module loaded
# (it draws from them), so it changed with what else the run collected: this file alone passed, the whole suite
# failed once a new test file was added.
@pytest.mark.parametrize("seed", range(16))
def test_random_creatures_get_one_chain_per_limb(seed):
    _, _, score = creature_rig(random_creature(NumpyDraw(np.random.default_rng(seed))))
    assert_rigger_would_draw(score)


def test_depth_inside_overlapping_parts_is_to_the_outer_surface():
    """A rod pushed halfway into a ball: the ball's middle is as deep as the ball, not cut by the rod's end."""
    import trimesh
    from autorig.extract import distance_map, voxelize

    ball = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    rod = trimesh.creation.capsule(height=2.0, radius=0.25)
    rod.apply_translation([0.0, 0.0, 1.0])                   # from the ball's middle out through its surface
    joined = trimesh.util.concatenate([ball, rod])
    vertices, faces = np.asarray(joined.vertices), np.asarray(joined.faces, dtype=np.int64)
    grid = voxelize(vertices, faces, 48)
    depth = distance_map(grid, vertices, faces)
    middle = tuple(np.round((np.zeros(3) - grid.origin) / grid.step).astype(int))
    assert depth[middle] * grid.step == pytest.approx(0.99, abs=0.05)   # the icosphere is a little inside 1


# ------------------------------------------------------------------------------------------------- meshes

def test_octopus_has_a_chain_per_tentacle():
    rig = rigged("octopus_low", 0, voxels=64)
    ends = chain_ends(rig)
    assert len(ends) == 8 and rig.info["chains"] == 8
    # The vertex at the far end of each tentacle moves with that tentacle's chain (tentacles touch: the vertex
    # is one nearer to this chain's last bone than to any other joint).
    nearest_joint = np.linalg.norm(rig.vertices[:, None] - rig.joints[None], axis=2).argmin(axis=1)
    for e in ends:
        direction = rig.joints[e] - rig.joints[rig.parents[e]]
        near = (np.linalg.norm(rig.vertices - rig.joints[e], axis=1) < 2 * np.linalg.norm(direction)) \
            & np.isin(nearest_joint, [e, rig.parents[e]])
        reach = np.where(near, (rig.vertices - rig.joints[e]) @ direction, -np.inf)
        assert moves_with(rig, rig.vertices[np.argmax(reach)], rig.names[e])


def test_spider_has_a_chain_per_leg():
    """18 separate parts (legs, body, head, fangs, eyes): the legs are the parts that reach the ground."""
    import trimesh

    rig = rigged("spider", 0, voxels=64)
    mesh = trimesh.Trimesh(rig.vertices, rig.faces, process=False)
    parts = [np.unique(rig.faces[c]) for c in trimesh.graph.connected_components(mesh.face_adjacency, min_len=1)]
    assert len(parts) == 18
    height = np.ptp(rig.vertices[:, 1])
    legs = [p for p in parts if rig.vertices[p, 1].min() < rig.vertices[:, 1].min() + 0.1 * height]
    tips = np.array([rig.vertices[p[np.argmin(rig.vertices[p, 1])]] for p in legs])
    assert len(legs) == 8
    names = nearest_ends(rig, tips)
    assert len(set(names)) == 8
    for tip, name in zip(tips, names):
        assert np.linalg.norm(rig.joint(name) - tip) < 0.3 * height
        assert moves_with(rig, tip, name)


def feet(vertices, faces, up: int, band: float = 0.03) -> np.ndarray:
    """The lowest vertex [K, 3] of each patch of surface within band x height of the ground (each foot's sole),
    the largest patches first."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    low = vertices[:, up] < vertices[:, up].min() + band * np.ptp(vertices[:, up])
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = edges[low[edges].all(axis=1)]
    n = len(vertices)
    _, label = connected_components(coo_matrix((np.ones(len(edges)), tuple(edges.T)), shape=(n, n)), directed=False)
    patches = [np.flatnonzero(low & (label == k)) for k in np.unique(label[low])]
    patches.sort(key=len, reverse=True)
    return np.array([vertices[p[np.argmin(vertices[p, up])]] for p in patches])


@pytest.mark.parametrize("name, up, front", [("cow", "y", "x"), ("horse", "z", "y")])
def test_animal_has_a_chain_per_leg(name, up, front):
    rig = rigged(name, 0, voxels=64, up=up, front=front)        # at 48 voxels the cow's legs are a voxel thick
    axis = "xyz".index(up)
    hooves = feet(rig.vertices, rig.faces, axis)
    assert len(hooves) == 4
    names = nearest_ends(rig, hooves)
    assert len(set(names)) == 4, names
    height = np.ptp(rig.vertices[:, axis])
    for hoof, end in zip(hooves, names):
        assert np.linalg.norm(rig.joint(end) - hoof) < 0.1 * height
        assert moves_with(rig, hoof, end)


def test_armadillo_has_a_chain_per_limb():
    """Hands (leftmost, rightmost), feet (lowest on each side), tail (rearmost) and ears (highest each side)."""
    rig = rigged("armadillo", 0)
    V = rig.vertices
    left, right = V[:, 0] > 0, V[:, 0] < 0
    ends = [V[np.argmax(V[:, 0])], V[np.argmin(V[:, 0])], V[left][np.argmin(V[left, 1])],
            V[right][np.argmin(V[right, 1])], V[np.argmin(V[:, 2])], V[left][np.argmax(V[left, 1])],
            V[right][np.argmax(V[right, 1])]]
    names = nearest_ends(rig, ends)
    assert len(set(names)) == len(ends), names
    for point, end in zip(ends, names):
        assert np.linalg.norm(rig.joint(end) - point) < 0.25          # at 48 voxels the claws are too thin
        assert moves_with(rig, point, end)


# ------------------------------------------------------------------------------------------------- every rig

@pytest.mark.parametrize("case", [("star", 5), ("tree", 3), ("octopus_low", 0), ("spider", 0)],
                         ids=lambda c: c[0])
def test_skeleton_is_well_formed_and_inside(case):
    rig = rigged(*case, voxels=64 if case[0] == "spider" else 48)
    assert rig.names[0] == "root" and rig.parents[0] == -1
    assert all(NAME.fullmatch(n) for n in rig.names), rig.names
    assert len(set(rig.names)) == len(rig.names)
    assert np.all(rig.parents[1:] < np.arange(1, len(rig.names)))
    ends = chain_ends(rig)
    assert not np.isin(ends, rig.parents).any()          # tips carry no bone ...
    assert np.all(rig.weights[:, ends] == 0)             # ... and so no weight
    assert np.all(rig.weights >= 0)
    np.testing.assert_allclose(rig.weights.sum(axis=1), 1.0, atol=1e-9)
    assert np.all(winding(rig, rig.joints) >= 0.5)
    assert rig.info["joints_inside"] == 1.0
    assert rig.info["confidence"] is None     # no template to check against: no confidence, not a constant 1.00
    assert rig.template == AUTO and rig.info["chains"] == len(ends)


def test_deterministic_and_independent_of_input_axes():
    shape = star(arms=4)
    options = autorig.RigOptions(voxels=40)
    a = autorig.rig((shape.vertices, shape.faces), AUTO, options)
    b = autorig.rig((shape.vertices.copy(), shape.faces.copy()), AUTO, options)
    assert a.names == b.names
    np.testing.assert_array_equal(a.joints, b.joints)
    np.testing.assert_array_equal(a.weights, b.weights)
    # A Z-up copy in centimetres gives the same skeleton, in its own axes and units.
    zup = shape.vertices[:, [0, 2, 1]] * [100, -100, 100]
    c = autorig.rig((zup, shape.faces), AUTO, autorig.RigOptions(up="z", front="y", voxels=40))
    assert len(c.names) == len(a.names)
    back = c.joints[:, [0, 2, 1]] * [0.01, 0.01, -0.01]
    assert np.abs(np.sort(back, axis=0) - np.sort(a.joints, axis=0)).max() < 0.05 * np.ptp(shape.vertices)


def test_axes_left_auto_are_filled_in_not_detected():
    assert fixed_axes("auto", "auto") == ("y", "z")
    assert fixed_axes("z", "auto") == ("z", "y")
    assert fixed_axes("auto", "-y") == ("z", "-y")
    assert fixed_axes("x", "-z") == ("x", "-z")
    shape = star(arms=3)
    rig = autorig.rig((shape.vertices, shape.faces), AUTO, autorig.RigOptions(up="z", voxels=24))
    assert (rig.info["up"], rig.info["front"], rig.info["axes_detected"]) == ("z", "y", False)


def test_segment_budget():
    shape = star(arms=3)
    for budget in (1, 3):
        rig = autorig.rig((shape.vertices, shape.faces), AUTO, autorig.RigOptions(voxels=40, max_segments=budget))
        for end in chain_ends(rig):
            assert 1 <= len([n for n in rig.names if chain(n) == chain(rig.names[end])]) <= budget


def test_limbless_blob_gets_one_bone():
    import trimesh
    ball = trimesh.creation.icosphere(subdivisions=3)
    rig = autorig.rig((ball.vertices, ball.faces), AUTO, autorig.RigOptions(voxels=24))
    assert rig.names == ["root", "chain1_end"]
    assert np.all(winding(rig, rig.joints) >= 0.5)


# ------------------------------------------------------------------------------------------------- stages

def test_split_chain_puts_joints_at_bends():
    # An L: along x for 20 steps, then along y for 10, with a thickness of 2.
    points = np.concatenate([np.stack([np.arange(20.0), np.zeros(20), np.zeros(20)], axis=1),
                             np.stack([np.full(11, 20.0), np.arange(11.0), np.zeros(11)], axis=1)])
    depth = np.full(len(points), 2.0)
    assert best_split(points, 0, len(points) - 1) == 20
    np.testing.assert_array_equal(split_chain(points, depth, np.array([], dtype=int), 8), [0, 20, 30])
    np.testing.assert_array_equal(split_chain(points, depth, np.array([], dtype=int), 1), [0, 30])
    np.testing.assert_array_equal(split_chain(points, depth, np.array([5]), 8), [0, 5, 20, 30])


def test_medial_surface_of_a_tube_is_its_axis():
    import trimesh
    from autorig.extract import distance_map, medial_surface, voxelize

    tube = trimesh.creation.cylinder(radius=0.1, height=1.0, sections=48)     # along z
    grid = voxelize(tube.vertices, np.asarray(tube.faces, dtype=np.int64), 40)
    depth = distance_map(grid, tube.vertices, np.asarray(tube.faces, dtype=np.int64))
    axis = grid.centres(medial_surface(depth))
    away = np.linalg.norm(axis[:, :2], axis=1)
    middle = np.abs(axis[:, 2]) < 0.4                     # away from the flat ends' own medial sheets
    assert middle.sum() > 20
    assert np.all(away[middle] < 1.5 * grid.step)


# ------------------------------------------------------------------------------------------------- command line

def test_cli_template_auto(tmp_path):
    from autorig.cli import AUTO_TEMPLATE, cli

    assert AUTO_TEMPLATE == AUTO
    defaults = {p.name: p.default for p in cli.commands["rig"].params}
    assert (defaults["voxels"], defaults["max_segments"]) == (autorig.RigOptions().voxels,
                                                            autorig.RigOptions().max_segments)
    shape = star(arms=3)
    mesh = tmp_path / "star.obj"
    mesh.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in shape.vertices)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in shape.faces))
    out = tmp_path / "star.json"
    result = CliRunner().invoke(cli, [str(mesh), "--template", "auto", "--voxels", "32", "--max-segments", "2",
                                      "-o", str(out)], prog_name="autorig")
    assert result.exit_code == 0, result.output
    document = json.loads(out.read_text())
    assert document["template"] == "auto"
    assert "auto, " in result.stdout
    listed = CliRunner().invoke(cli, ["templates"], prog_name="autorig")
    assert re.search(r"^auto\s", listed.stdout, flags=re.M)
    bad = CliRunner().invoke(cli, [str(mesh), "--template", "auto", "--voxels", "4"], prog_name="autorig")
    assert bad.exit_code == 2
