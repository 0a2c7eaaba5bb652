"""A real client: Blender imports autorig's .glb, finds the rig, and the mesh moves with its bones.

Runs tests/blender_check.py inside headless Blender (Debian's ``blender`` package; see .ci/run). Skipped when
there is no ``blender`` on PATH.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from gltf_validator import validate
from rig_samples import mannequin_bvh, rigged_mannequin
from test_pose import MOVES, POSES

from autorig.exchange.animated_gltf import write_animated_glb
from autorig.exchange.bvh import parse_bvh
from autorig.exchange.gltf import read_glb, top4_influences, write_glb
from autorig.exchange.obj import write_obj
from autorig.show.pose import retarget, skin

BLENDER = shutil.which("blender")
SCRIPT = Path(__file__).with_name("blender_check.py")
REEXPORT = Path(__file__).with_name("blender_reexport.py")

pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")


def run_blender(script: Path, *args) -> subprocess.CompletedProcess:
    command = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script), "--",
               *map(str, args)]
    # Debian's Blender embeds the system Python and finds its home through the first python3 on PATH: put the
    # one beside blender first, not a virtual environment's or pyenv's, which lack Blender's numpy.
    env = dict(os.environ, PATH=os.pathsep.join([os.path.dirname(os.path.realpath(BLENDER)), os.environ["PATH"]]))
    return subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)


def blender_report(path: Path, bone: str, frame: int | None = None) -> dict:
    run = run_blender(SCRIPT, path, bone, *([frame] if frame is not None else []))
    lines = [line for line in run.stdout.splitlines() if line.startswith("AUTORIG_BLENDER ")]
    assert run.returncode == 0 and lines, run.stdout[-3000:] + run.stderr[-3000:]
    return json.loads(lines[0].split(" ", 1)[1])


@pytest.fixture(scope="module")
def rig():
    return rigged_mannequin()[1]


def test_blender_imports_the_rig_and_the_mesh_follows_a_bone(rig, tmp_path):
    path = tmp_path / "hero.glb"
    write_glb(rig, path)
    report = blender_report(path, "left_elbow")
    assert report["armatures"] == 1 and report["meshes"] == 1
    assert sorted(report["bones"]) == sorted(rig.names)
    slots, amounts = top4_influences(rig.weights)
    weighted = {rig.names[j] for j in np.unique(slots[amounts > 0])}
    assert set(report["weighted"]) == weighted  # one vertex group with weights per weighted joint
    assert set(report["groups"]) <= set(rig.names)
    assert report["modifier"]
    assert report["height"] == pytest.approx(np.ptp(rig.vertices[:, 1]), rel=1e-4)  # glTF +y is Blender's +z
    # Turning the elbow 90 degrees swings the forearm; nothing outside the arm from the elbow down moves.
    assert report["moved_follow"] > 0.1
    assert report["moved_other"] < 1e-5


def test_blender_plays_the_animation_as_autorig_skins_it(rig, tmp_path):
    motion = parse_bvh(mannequin_bvh(POSES, MOVES))  # one frame per Blender frame (24 per second)
    animation = retarget(rig, motion)
    path = tmp_path / "moves.glb"
    write_animated_glb(rig, animation, path, name="moves")
    report = blender_report(path, "left_elbow", frame=1)
    (name, (start, end, rotations, locations)), = report["actions"].items()
    assert name.startswith("moves") and (start, end) == pytest.approx((0, 2), abs=1e-4)
    assert rotations == 4 * animation.animated.sum() and locations == 3
    # Frame 1 bends the left knee and carries the root 0.5 m forward; Blender's box of the posed mesh is ours
    # (Blender's x, y, z are glTF's x, -z, y).
    ours = skin(rig, animation.rotations[1], animation.positions[1])
    ours = np.stack([ours[:, 0], -ours[:, 2], ours[:, 1]], axis=1)
    assert np.allclose(report["box_at_frame"], [ours.min(axis=0), ours.max(axis=0)], atol=2e-3)
    assert report["moved_at_frame"] > 0.5


def inverse_binds(path: Path) -> dict[str, np.ndarray]:
    """{joint name: its 4x4 inverse bind matrix (column-major, as stored)} of a .glb's first skin."""
    doc = pygltflib.GLTF2().load(str(path))
    skin_ = doc.skins[0]
    accessor = doc.accessors[skin_.inverseBindMatrices]
    view = doc.bufferViews[accessor.bufferView]
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    matrices = np.frombuffer(doc.binary_blob(), dtype="<f4", count=16 * accessor.count, offset=start)
    return {doc.nodes[j].name: m for j, m in zip(skin_.joints, matrices.reshape(-1, 16))}


def test_a_rig_exported_by_blender_reweights_with_its_own_skeleton(rig, tmp_path):
    """An artist's rig as Blender writes it (its exporter, not autorig's) as --skeleton: the joints, their
    names and bind pose are kept, and on the same mesh and skeleton the weights are the template rig's."""
    ours, theirs, out = tmp_path / "hero.glb", tmp_path / "from_blender.glb", tmp_path / "reweighted.glb"
    write_glb(rig, ours)
    run = run_blender(REEXPORT, ours, theirs)
    assert run.returncode == 0 and theirs.is_file(), run.stdout[-3000:] + run.stderr[-3000:]
    mesh = tmp_path / "hero.obj"
    write_obj(rig.vertices, rig.faces, mesh)
    done = subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "--skeleton", str(theirs), "-o",
                           str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    result = read_glb(out)
    assert sorted(result.names) == sorted(rig.names)
    source_binds, kept_binds = inverse_binds(theirs), inverse_binds(out)
    assert set(kept_binds) == set(source_binds)
    for name, matrix in source_binds.items():
        np.testing.assert_array_equal(kept_binds[name], matrix)
    same = [result.names.index(n) for n in rig.names]
    agree = np.mean(result.weights[:, same].argmax(axis=1) == rig.weights.argmax(axis=1))
    # --skeleton decides from the shape which leaves carry a tip bone; the learned biped's own tips (the hand's
    # end below the wrist, as the corpus's hanging arms have it) differ at the fingertips.
    assert agree > 0.98
    assert validate(out)["errors"] == 0


RENDER = Path(__file__).with_name("blender_render.py")
TEXTURED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "textured"
# Where to keep copies of the pictures for people to look at ($AUTORIG_ARTIFACTS, if set); nothing reads them.
ARTIFACTS = os.environ.get("AUTORIG_ARTIFACTS")


def render_report(path: Path, picture: Path, bone: str | None = None) -> dict:
    run = run_blender(RENDER, path, picture, *([bone] if bone else []))
    lines = [line for line in run.stdout.splitlines() if line.startswith("AUTORIG_BLENDER ")]
    assert run.returncode == 0 and lines, run.stdout[-3000:] + run.stderr[-3000:]
    return json.loads(lines[0].split(" ", 1)[1])


def keep_picture(picture: Path) -> None:
    if not ARTIFACTS:
        return
    try:
        Path(ARTIFACTS).mkdir(parents=True, exist_ok=True)
        shutil.copyfile(picture, Path(ARTIFACTS) / picture.name)
    except OSError:
        pass  # a read-only or missing place for copies does not make the picture wrong


TEXTURED_CASES = {
    # name: (input, template, bone to bend in the picture, texture file it must show)
    "cesiumman": ("CesiumMan.glb", "biped", "left_elbow", None),
    "babi": ("Babi/Babi.obj", "quadruped", "front_left_shoulder", "Babi/Tex.png"),
}


@pytest.fixture(scope="module")
def textured_rigs(tmp_path_factory):
    if not TEXTURED.is_dir():
        pytest.skip("../shared/data/textured is not there")
    import autorig
    folder = tmp_path_factory.mktemp("textured")
    rigs = {}
    for name, (mesh, template, _, _) in TEXTURED_CASES.items():
        rig = autorig.rig(str(TEXTURED / mesh), template)
        path = folder / f"{name}.rigged.glb"
        write_glb(rig, path)
        rigs[name] = (rig, path)
    return rigs


@pytest.mark.parametrize("name", sorted(TEXTURED_CASES))
def test_blender_renders_the_textured_rig_with_its_texture(textured_rigs, tmp_path, name):
    rig, path = textured_rigs[name]
    bone = TEXTURED_CASES[name][2]
    picture = tmp_path / f"{name}_rigged_blender.png"
    report = render_report(path, picture, bone)
    keep_picture(picture)
    assert report["armatures"] == 1 and sorted(report["bones"]) == sorted(rig.names)
    (images,) = report["textures"].values()    # one material, whose base colour comes from one image
    (_, width, height), = images
    assert width >= 256 and height >= 256        # the texture image itself, loaded with its pixels
    assert report["covered"] > 0.03
    # A grey, untextured model renders with no colour at all; these textures are pink and blue-green.
    assert report["saturation"] > 0.08
    assert validate(path)["errors"] == 0


def test_fbx_round_trip_through_blender(textured_rigs, tmp_path):
    from autorig.exchange import write_rig
    rig, _ = textured_rigs["babi"]
    path = tmp_path / "babi.fbx"
    write_rig(rig, path, "fbx")
    picture = tmp_path / "babi_fbx_blender.png"
    report = render_report(path, picture)
    keep_picture(picture)
    assert report["armatures"] == 1
    assert sorted(report["bones"]) == sorted(rig.names)
    slots, amounts = top4_influences(rig.weights)
    assert set(report["groups"]) == {rig.names[j] for j in np.unique(slots[amounts > 0])}
    (images,) = report["textures"].values()
    (_, width, height), = images
    assert (width, height) == (1024, 1024)   # Tex.png, embedded in the FBX
    assert report["saturation"] > 0.08


def test_fbx_without_blender_is_one_line(tmp_path):
    mesh = tmp_path / "hero.obj"
    rig = rigged_mannequin()[1]
    write_obj(rig.vertices, rig.faces, mesh)
    env = dict(os.environ, AUTORIG_BLENDER=str(tmp_path / "no-blender"))
    done = subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "-o", str(tmp_path / "hero.fbx")],
                          capture_output=True, text=True, env=env)
    assert done.returncode == 4 and done.stderr.count("\n") == 1 and "AUTORIG_BLENDER" in done.stderr
    assert not (tmp_path / "hero.fbx").exists()
