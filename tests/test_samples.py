"""The procedural sample characters: clean closed meshes around skeletons that can serve as ground truth."""
import json
from functools import cache
from pathlib import Path

import igl
import numpy as np
import pytest
import trimesh

from autorig.samples import Proportions, Sample, mannequin, quadruped
from autorig.template import load_template

ROOT = Path(__file__).resolve().parents[1]

CASES = [
    ("biped", "t", "adult"),
    ("biped", "a", "child"),
    ("biped", "down", "adult"),
    ("biped", "down", "heavy"),
    ("biped", "t", "tall"),
    ("quadruped", None, "dog"),
    ("quadruped", None, "long"),
    ("quadruped", None, "tall"),
]
BIPEDS = [c for c in CASES if c[0] == "biped"]


def case_id(case) -> str:
    return "-".join(p for p in case if p)


@cache
def build(kind: str, pose: str | None, proportions: str) -> Sample:
    return mannequin(pose, proportions) if kind == "biped" else quadruped(proportions)


@cache
def template(name: str):
    return load_template(ROOT / "templates" / f"{name}.json")


def height(s: Sample) -> float:
    return float(np.ptp(s.vertices[:, 1]))


@pytest.fixture(params=CASES, ids=case_id)
def sample(request) -> Sample:
    return build(*request.param)


def test_arrays_have_documented_types(sample):
    assert sample.vertices.dtype == np.float64 and sample.vertices.shape[1] == 3
    assert sample.faces.dtype == np.int64 and sample.faces.shape[1] == 3
    assert sample.faces.min() == 0 and sample.faces.max() == len(sample.vertices) - 1


def test_mesh_is_one_closed_outward_manifold(sample):
    V, F = sample.vertices, sample.faces
    mesh = trimesh.Trimesh(V, F, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0
    assert mesh.body_count == 1
    assert igl.is_edge_manifold(F)[0]
    assert igl.is_vertex_manifold(F).all()
    assert len(np.unique(V, axis=0)) == len(V)
    # Slivers would break the cotangent Laplacians that skinning builds on these meshes.
    assert mesh.area_faces.min() > 1e-3 * mesh.area_faces.mean()
    assert 5_000 <= len(F) <= 20_000


def test_every_template_joint_is_given(sample):
    assert set(sample.joints) == set(template(sample.template).names)
    assert all(np.shape(p) == (3,) and np.all(np.isfinite(p)) for p in sample.joints.values())


def test_inner_joints_are_inside_with_clearance_and_tips_on_the_surface(sample):
    names = list(sample.joints)
    points = np.array([sample.joints[n] for n in names])
    winding = igl.winding_number(sample.vertices, sample.faces, points)
    distance = np.sqrt(igl.point_mesh_squared_distance(points, sample.vertices, sample.faces)[0])
    tip = np.array([n.endswith("_end") for n in names])
    assert np.all(winding[~tip] > 0.99), [n for n, w in zip(names, winding) if w <= 0.99]
    assert distance[~tip].min() > 0.01 * height(sample)
    assert distance[tip].max() < 0.01 * height(sample)


def test_left_is_plus_x_and_sides_mirror(sample):
    t = template(sample.template)
    for n, p in sample.joints.items():
        if "left" in n:
            assert p[0] > 0, n
        elif "right" in n:
            assert p[0] < 0, n
        else:
            assert p[0] == 0, n
    for i, j in t.symmetry:
        np.testing.assert_allclose(sample.joints[t.names[i]] * [-1, 1, 1], sample.joints[t.names[j]])


def test_stands_on_the_ground_feet_lowest(sample):
    t = template(sample.template)
    assert abs(sample.vertices[:, 1].min()) < 0.01 * height(sample)
    feet = {t.names[i] for i in t.feet}
    foot_y = max(sample.joints[n][1] for n in feet)
    assert foot_y < 0.06 * height(sample)
    assert all(p[1] > foot_y for n, p in sample.joints.items() if n not in feet)


def test_faces_plus_z(sample):
    j = sample.joints
    if sample.template == "biped":
        assert j["left_toe_end"][2] > j["left_toe"][2] > j["left_ankle"][2]
        assert sample.vertices[:, 2].max() == pytest.approx(j["left_toe_end"][2], abs=0.01)
    else:
        assert j["head_end"][2] > j["neck"][2] > j["hips"][2] > j["tail_end"][2]


def test_mannequin_heights_are_natural():
    assert height(build("biped", "t", "adult")) == pytest.approx(1.70, abs=0.01)
    assert height(build("biped", "a", "child")) == pytest.approx(1.20, abs=0.01)
    custom = mannequin("t", Proportions(height=1.5, head=0.21, leg=0.76, arm=0.65, shoulder_width=0.31))
    assert height(custom) == pytest.approx(1.5, abs=0.01)
    assert custom.joints["head_end"][1] == pytest.approx(1.5, abs=0.01)


def angle_below_horizontal(s: Sample) -> float:
    d = s.joints["left_wrist"] - s.joints["left_shoulder"]
    return float(np.degrees(np.arctan2(-d[1], d[0])))


def first_hits(s: Sample, origin, direction) -> list[float]:
    hits = igl.ray_mesh_intersect(np.asarray(origin, float), np.asarray(direction, float), s.vertices, s.faces)
    return [h[1] for h in hits or []]


def test_poses_hold_the_arms_as_named():
    assert angle_below_horizontal(build("biped", "t", "adult")) == pytest.approx(0.0, abs=1e-9)
    assert angle_below_horizontal(build("biped", "a", "child")) == pytest.approx(45.0, abs=1e-9)
    for proportions in ("adult", "heavy"):
        s = build("biped", "down", proportions)
        assert 60 < angle_below_horizontal(s) < 86
        # Looking inward from the elbow, the ray leaves the arm and crosses a small gap before the body.
        exit_arm, enter_body = first_hits(s, s.joints["left_elbow"], [-1, 0, 0])[:2]
        assert 0.01 < enter_body - exit_arm < 0.06, proportions
        exit_arm, enter_body = first_hits(s, s.joints["left_wrist"], [-1, 0, 0])[:2]
        assert enter_body - exit_arm > 0.01, proportions


@pytest.mark.parametrize("case", BIPEDS, ids=case_id)
def test_limb_bends_sit_at_the_centre_of_the_limb(case):
    s = build(*case)
    t = template("biped")
    for name in ("left_elbow", "left_wrist", "left_knee", "right_elbow", "right_knee"):
        i = t.names.index(name)
        before = s.joints[name] - s.joints[t.names[t.parents[i]]]
        after = s.joints[t.names[t.children[i][0]]] - s.joints[name]
        axis = before / np.linalg.norm(before) + after / np.linalg.norm(after)
        u = np.cross(axis, [0.3, 0.5, 0.7])
        u /= np.linalg.norm(u)
        v = np.cross(axis / np.linalg.norm(axis), u)
        for angle in np.linspace(0, np.pi, 6, endpoint=False):
            d = np.cos(angle) * u + np.sin(angle) * v
            a, b = first_hits(s, s.joints[name], d)[0], first_hits(s, s.joints[name], -d)[0]
            assert abs(a - b) < 0.1 * (a + b), (case, name)


def test_deterministic():
    a, b = mannequin("a", "heavy"), mannequin("a", "heavy")
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert all(np.array_equal(a.joints[n], b.joints[n]) for n in a.joints)
    c, d = quadruped("long"), quadruped("long")
    assert np.array_equal(c.vertices, d.vertices) and np.array_equal(c.faces, d.faces)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="pose"):
        mannequin("x")
    with pytest.raises(ValueError, match="proportions"):
        mannequin("t", "giant")
    with pytest.raises(ValueError, match="proportions"):
        quadruped("cat")


@pytest.mark.parametrize("name, case", [("mannequin", CASES[0]), ("dog", CASES[5])])
def test_shipped_data_matches_the_generator(name, case):
    obj, joints_file = ROOT / "data" / f"{name}.obj", ROOT / "data" / f"{name}.joints.json"
    assert obj.stat().st_size < 1_000_000 and joints_file.stat().st_size < 1_000_000
    s = build(*case)
    mesh = trimesh.load(obj, process=False)
    assert mesh.faces.shape == s.faces.shape and np.array_equal(mesh.faces, s.faces)
    np.testing.assert_allclose(mesh.vertices, s.vertices, atol=1e-5)
    data = json.loads(joints_file.read_text())
    assert data["up_axis"] == "+y" and data["front_axis"] == "+z"
    assert data["height_along_up"] == pytest.approx(height(s), abs=1e-5)
    t = template(s.template)
    assert [j["name"] for j in data["joints"]] == list(t.names)
    for j in data["joints"]:
        np.testing.assert_allclose(j["position"], s.joints[j["name"]], atol=1e-6)
        parent = t.parents[t.names.index(j["name"])]
        assert j["parent"] == (t.names[parent] if parent >= 0 else None)
