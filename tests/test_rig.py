"""End to end: rig characters whose skeleton is known and check what a user would check."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import autorig
from autorig.samples import mannequin, quadruped

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
# The hand-set biped, whose joints follow the mannequins' own conventions (the built-in one is learned from
# artists' rigs, which put some joints elsewhere: 0 A.D.'s thigh joints sit above the pelvis).
HAND_SET_BIPED = ROOT / "templates" / "handset" / "biped.json"
HAND_SET_QUADRUPED = ROOT / "templates" / "handset" / "quadruped.json"


def winding(vertices, faces, points):
    import igl
    return igl.fast_winding_number(np.asarray(vertices, float), np.asarray(faces, np.int64),
                                   np.asarray(points, float))


def joint_errors(rig, sample):
    """{joint name: error / height} for every non-tip template joint."""
    height = float(np.ptp(sample.vertices[:, 1]))
    return {n: float(np.linalg.norm(rig.joint(n) - sample.joints[n]) / height)
            for n in rig.names if not n.endswith("_end")}


def dominant_joint(rig, point):
    """Name of the joint that dominates the vertex nearest to ``point``."""
    i = int(np.argmin(np.linalg.norm(rig.vertices - point, axis=1)))
    return rig.names[int(np.argmax(rig.weights[i]))]


@pytest.fixture(scope="module", params=[("t", "adult"), ("a", "heavy"), ("down", "tall"), ("t", "child")],
                ids=lambda p: f"{p[0]}-{p[1]}")
def rigged_mannequin(request):
    pose, build = request.param
    sample = mannequin(pose=pose, proportions=build)
    return sample, autorig.rig((sample.vertices, sample.faces), "biped")


def test_mannequin_joints_near_truth(rigged_mannequin):
    sample, rig = rigged_mannequin
    # The learned biped: every joint in its limb, near the mannequin's own.
    errors = joint_errors(rig, sample)
    assert np.mean(list(errors.values())) < 0.06, errors
    assert max(errors.values()) < 0.16, errors
    # The hand-set biped shares the mannequins' conventions: near their joints exactly.
    rig = autorig.rig((sample.vertices, sample.faces), HAND_SET_BIPED)
    errors = joint_errors(rig, sample)
    assert np.mean(list(errors.values())) < 0.05, errors
    assert max(errors.values()) < 0.10, errors


def test_mannequin_joints_inside_and_sided(rigged_mannequin):
    sample, rig = rigged_mannequin
    solid = [i for i, n in enumerate(rig.names) if not n.endswith("_end")]
    assert np.all(winding(sample.vertices, sample.faces, rig.joints[solid]) > 0.5)
    for name in rig.names:
        if name.startswith("left_"):
            mirror = name.replace("left_", "right_")
            # The character's left is +x for a figure facing +z.
            assert rig.joint(name)[0] > rig.joint(mirror)[0], name


def test_mannequin_weights(rigged_mannequin):
    sample, rig = rigged_mannequin
    W = rig.weights
    assert W.shape == (len(sample.vertices), len(rig.names))
    assert np.all(W >= 0)
    np.testing.assert_allclose(W.sum(axis=1), 1.0, atol=1e-9)
    # Hands move with the forearm/hand joints of their own side, feet with their own ankle/toe.
    for side in ("left", "right"):
        assert dominant_joint(rig, sample.joints[f"{side}_hand_end"]) in (f"{side}_wrist", f"{side}_elbow")
        assert dominant_joint(rig, sample.joints[f"{side}_toe_end"]) in (f"{side}_ankle", f"{side}_toe")
    assert dominant_joint(rig, sample.joints["head_end"]) in ("head", "neck")


def test_output_in_input_coordinates():
    """A Z-up mesh in centimetres rigs to the same skeleton, in its own axes and units."""
    sample = mannequin(pose="a")
    upright = autorig.rig((sample.vertices, sample.faces), "biped")
    # Z up, facing -y: (x, y, z)_input = (x, -z, y)_canonical, in centimetres.
    V = np.c_[sample.vertices[:, 0], -sample.vertices[:, 2], sample.vertices[:, 1]] * 100.0
    lying = autorig.rig((V, sample.faces), "biped", autorig.RigOptions(up="z", front="-y"))
    back = np.c_[lying.joints[:, 0], lying.joints[:, 2], -lying.joints[:, 1]] / 100.0
    # The field is sampled in the file's own axes (so that given axes rig as detected ones do: test_orient),
    # so the rig is close to the upright one, not bit-identical.
    apart = np.linalg.norm(back - upright.joints, axis=1) / np.ptp(sample.vertices[:, 1])
    assert apart.mean() < 0.005 and apart.max() < 0.02
    np.testing.assert_array_equal(lying.vertices, V)


def test_deterministic():
    sample = mannequin(pose="down")
    a = autorig.rig((sample.vertices, sample.faces), "biped")
    b = autorig.rig((sample.vertices, sample.faces), "biped")
    np.testing.assert_array_equal(a.joints, b.joints)
    np.testing.assert_array_equal(a.weights, b.weights)


@pytest.mark.parametrize("template", [HAND_SET_QUADRUPED, "quadruped"], ids=["hand-set", "learned"])
def test_quadruped_dog(template):
    """The hand-set template puts the trunk joints where the sample's own skeleton has them; the learned one
    where the corpus's artists put them (the root at the rump), and its legs where both do."""
    sample = quadruped("dog")
    rig = autorig.rig((sample.vertices, sample.faces), template)
    height = float(np.ptp(sample.vertices[:, 1]))
    errors = {n: np.linalg.norm(rig.joint(n) - sample.joints[n]) / height for n in rig.names
              if not n.endswith("_end") and n in sample.joints}
    legs = [errors[n] for n in errors if n.split("_")[-1] in ("elbow", "wrist", "paw", "knee", "ankle")]
    assert np.mean(legs) < 0.06 and max(legs) < 0.1, errors
    if template == HAND_SET_QUADRUPED:
        assert np.mean(list(errors.values())) < 0.08, errors
        assert max(errors.values()) < 0.16, errors
    for side in ("left", "right"):
        assert dominant_joint(rig, sample.joints[f"front_{side}_paw"]).startswith(f"front_{side}_")
        assert dominant_joint(rig, sample.joints[f"back_{side}_paw"]).startswith(f"back_{side}_")


@pytest.mark.skipif(not (SHARED / "data" / "meshes" / "horse.obj").is_file(), reason="shared data absent")
def test_the_whole_cyberware_horse_gets_a_paw_in_each_hoof():
    """The 97k-face horse, discretized whole: its search needs 10,900 states to its optimum; stopped at 6,000,
    the greedy answer (16.4 against 4.3) put paws in the middle of the body and a front leg in a hind leg."""
    rig = autorig.rig(SHARED / "data" / "meshes" / "horse.obj", "quadruped", autorig.RigOptions(up="z", front="y"))
    assert rig.info["embedding_optimal"]
    vertices = np.asarray(rig.vertices)
    floor, height = vertices[:, 2].min(), float(np.ptp(vertices[:, 2]))
    middle = float(np.median(vertices[:, 0]))
    paws = {f"{end}_{side}": rig.joint(f"{end}_{side}_paw") for end in ("front", "back") for side in ("left", "right")}
    for name, paw in paws.items():
        assert paw[2] - floor < 0.1 * height, name    # at a hoof, not up in the leg or the body
    for side in ("left", "right"):
        assert paws[f"front_{side}"][1] > paws[f"back_{side}"][1] + 0.3 * height    # front ahead of back
    for end in ("front", "back"):    # a left and a right leg, not two paws in one
        assert (paws[f"{end}_left"][0] - middle) * (paws[f"{end}_right"][0] - middle) < 0
    names = list(paws)
    assert min(np.linalg.norm(paws[a] - paws[b]) for i, a in enumerate(names) for b in names[i + 1:]) > 0.1 * height


@pytest.mark.skipif(not (SHARED / "data" / "rigged" / "CesiumMan").is_dir(), reason="shared data absent")
def test_cesium_man_cli_end_to_end(tmp_path):
    """The README's promise on a real character: a .glb that loads back, validates, and scores well."""
    gt_dir = SHARED / "data" / "rigged" / "CesiumMan"
    mesh = tmp_path / "CesiumMan.obj"
    shutil.copy(gt_dir / "mesh.obj", mesh)
    before = mesh.read_bytes()
    run = subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "--template", HAND_SET_BIPED,
                          "--front", "x"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    out = tmp_path / "CesiumMan.rigged.glb"
    assert out.is_file() and str(out.name) in run.stdout
    assert mesh.read_bytes() == before

    import trimesh
    from autorig.exchange.gltf import read_glb
    from autorig.input.mesh import load_mesh
    V, _ = load_mesh(mesh)
    loaded = read_glb(out)
    np.testing.assert_allclose(loaded.vertices, V, atol=1e-5)
    assert len(trimesh.load(out, force="mesh", process=False).vertices) == len(V)

    result = json.loads(subprocess.run([sys.executable, str(SHARED / "tools" / "score.py"), str(gt_dir), str(out),
                                        "--kind", "biped"], capture_output=True, text=True, check=True).stdout)
    assert result["joints"]["mean"] < 0.05 and result["joints"]["max"] < 0.10, result["joints"]
    assert result["weights"]["top1_pct"] > 85.0
    assert result["weights"]["pred_zero_rows"] == 0

    # The learned built-in biped follows the 0 A.D. corpus's conventions (hip joints above the pelvis), which
    # CesiumMan's artist does not: its joints are still in their limbs, a few per cent of the height off.
    learned = tmp_path / "learned.glb"
    subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "--front", "x", "-o", str(learned), "-q"],
                   check=True)
    result = json.loads(subprocess.run([sys.executable, str(SHARED / "tools" / "score.py"), str(gt_dir),
                                        str(learned), "--kind", "biped"], capture_output=True, text=True,
                                       check=True).stdout)
    assert result["joints"]["mean"] < 0.07 and result["joints"]["max"] < 0.15, result["joints"]
    assert result["weights"]["top1_pct"] > 70.0     # 94 % with the hand-set biped: the hips' cells move


def test_overlap_measures_the_shared_part_of_each_path():
    """The overlap penalty's shared length is the length of the path's edges that end on used spheres,
    for every source and candidate sphere (checked by walking the paths)."""
    from autorig.discretize.distance import distance_field
    from autorig.embed.penalties import shared_length
    from autorig.discretize.graph import sphere_graph
    from autorig.discretize.medial import medial_samples, pack_spheres
    from autorig.input.mesh import prepare

    sample = mannequin(pose="a")
    prepared = prepare(sample.vertices, sample.faces, "y", "z")
    field = distance_field(*prepared.coarse())
    graph = sphere_graph(field, pack_spheres(medial_samples(field), min_radius=field.finest))
    S = len(graph.radii)
    rng = np.random.default_rng(0)
    for source in rng.choice(S, 5, replace=False):
        used = rng.random(S) < 0.3
        spheres = np.arange(S)
        expected = np.zeros(S)
        for v in spheres:
            if np.isfinite(graph.distances[source, v]):
                path = graph.path(int(source), int(v))
                expected[v] = sum(np.linalg.norm(graph.centers[b] - graph.centers[a])
                                  for a, b in zip(path, path[1:]) if used[b])
            elif used[v] and v != source:
                expected[v] = np.linalg.norm(graph.centers[v] - graph.centers[source])
        np.testing.assert_allclose(shared_length(graph, int(source), used, spheres), expected, atol=1e-12)
