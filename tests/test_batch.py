"""autorig batch: finding assets, per-folder configs, resuming, failures, reports, and cluster mode.

One small folder is rigged for real once per module (``reference``): two low-resolution mannequins, a dog
stored Z-up as glTF with external buffers (its config gives the quadruped template and the axes), and a text
file called bad.obj. Tests that change things work on copies of that folder and its output. A second one
(``skeleton_reference``) has the sample meshes on the user's own skeleton and on template "auto".
"""
from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from autorig import batch, samples
from autorig.batch import (EXIT_SOME_FAILED, ConfigError, find_meshes, rig_folder,
                           write_junit_report)
from autorig.batch.plan import input_files, plan_assets
from autorig.batch.progress import BatchProgress
from autorig.batch.store import read_manifest
from autorig.cli import BATCH_EXTENSIONS, cli
from autorig.errors import InputError, MissingPackageError, SkeletonError, TemplateError
from autorig.exchange.gltf import read_glb
from autorig.exchange.skeleton import read_skeleton
from autorig.pipeline import RigOptions, SkinOptions

# Explicit axes: automatic orientation would try eight frames per mesh, and these tests are about batching.
AXES = ["--up", "y", "--front", "z"]
RIGGED = {"hero.obj": "hero.rigged.glb", "animals/dog.gltf": "animals/dog.rigged.glb",
          "sub/deeper/kid.obj": "sub/deeper/kid.rigged.glb"}
DATA = Path(__file__).resolve().parents[1] / "data"
# Two mannequins on the studio skeleton (the mannequin's own joints, in its units), the dog on template auto.
SKELETON_TOML = 'skeleton = "rigs/studio.json"\n[files."dog.obj"]\ntemplate = "auto"\nup = "y"\nfront = "z"\n'
TWO_ROOTS = {"joints": [{"name": "a", "parent": None, "position": [0, 1, 0]},
                        {"name": "b", "parent": "a", "position": [0, 1.5, 0]},
                        {"name": "c", "parent": None, "position": [0.3, 0.5, 0]},
                        {"name": "d", "parent": "c", "position": [0.3, 0.2, 0]}]}


def run(*args: str):
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="autorig")


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist()]
    lines += [f"f {a} {b} {c}\n" for a, b, c in (faces + 1).tolist()]
    path.write_text("".join(lines))


def make_assets(root: Path) -> Path:
    import trimesh

    hero = samples.mannequin(resolution=56)
    write_obj(root / "hero.obj", hero.vertices, hero.faces)
    kid = samples.mannequin(pose="a", proportions="child", resolution=56)
    write_obj(root / "sub" / "deeper" / "kid.obj", kid.vertices, kid.faces)
    (root / "sub" / "bad.obj").write_text("this is not a mesh\n")
    dog = samples.quadruped(resolution=56)
    z_up = dog.vertices[:, [0, 2, 1]] * [1, -1, 1]  # +y up, +z front -> +z up, -y front
    exported = trimesh.Trimesh(z_up, dog.faces, process=False).export(file_type="gltf")
    (root / "animals").mkdir()
    for name, data in exported.items():
        (root / "animals" / ("dog.gltf" if name.endswith(".gltf") else name)).write_bytes(data)
    (root / "animals" / "autorig.toml").write_text('template = "quadruped"\n[files."dog*"]\nup = "z"\nfront = "-y"\n')
    return root


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """(input folder, output folder, CLI result, report, junit) of one real batch run with -j 2."""
    root = tmp_path_factory.mktemp("batch")
    assets = make_assets(root / "assets")
    out, report, junit = root / "rigged", root / "report.json", root / "report.xml"
    result = run("batch", assets, "-o", out, *AXES, "-j", "2", "--report", report, "--junit", junit)
    return assets, out, result, report, junit


def make_skeleton_assets(root: Path) -> Path:
    (root / "rigs").mkdir(parents=True)
    shutil.copy(DATA / "mannequin.obj", root / "hero.obj")
    extra = samples.mannequin(resolution=56)
    write_obj(root / "crowd" / "extra.obj", extra.vertices, extra.faces)
    shutil.copy(DATA / "dog.obj", root / "dog.obj")
    shutil.copy(DATA / "mannequin.joints.json", root / "rigs" / "studio.json")
    (root / "autorig.toml").write_text(SKELETON_TOML)
    return root


@pytest.fixture(scope="module")
def skeleton_reference(tmp_path_factory):
    """(input folder, output folder, CLI result, report) of a batch of skeleton and template "auto" assets."""
    root = tmp_path_factory.mktemp("skeleton")
    assets = make_skeleton_assets(root / "assets")
    out, report = root / "rigged", root / "report.json"
    result = run("batch", assets, "-o", out, "--voxels", "32", "-j", "2", "--report", report)
    return assets, out, result, report


@pytest.fixture
def copy(reference, tmp_path):
    """A copy of the reference input and output folders (manifest included), to change freely."""
    assets, out = reference[:2]
    shutil.copytree(assets, tmp_path / "assets")
    shutil.copytree(out, tmp_path / "rigged")
    return tmp_path / "assets", tmp_path / "rigged"


def outputs(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*.glb"))}


def statuses(report: Path) -> dict[str, tuple]:
    return {a["input"]: (a["status"], a["previous"]) for a in json.loads(report.read_text())["assets"]}


# ------------------------------------------------------------------------------------------ a full run

def test_rigs_every_asset_and_fails_the_broken_one_cleanly(reference):
    assets, out, result, report, junit = reference
    assert result.exit_code == EXIT_SOME_FAILED == 7, result.output
    assert set(outputs(out)) == set(RIGGED.values())  # the folder structure is mirrored
    assert not (out / "sub" / "bad.rigged.glb").exists()
    # Not a terminal: one line per finished asset on stderr, a summary on stdout.
    assert "failed  sub/bad.obj: " in result.stderr
    assert len([line for line in result.stderr.splitlines() if line.startswith("[")]) == 4
    assert result.stdout.strip().startswith("4 assets: 3 rigged, 1 failed, 0 unchanged")


def test_json_report(reference):
    report = json.loads(reference[3].read_text())
    assert report["summary"] == {"total": 4, "ok": 3, "failed": 1, "skipped": 0, "doubtful": 0,
                                 "still_failing": 0, "exit_code": 7}
    by_input = {a["input"]: a for a in report["assets"]}
    assert list(by_input) == ["animals/dog.gltf", "hero.obj", "sub/bad.obj", "sub/deeper/kid.obj"]
    for rel, output in RIGGED.items():
        asset = by_input[rel]
        assert asset["status"] == "ok" and asset["error"] is None and asset["output"] == output
        assert "embedding" in asset["timings"] and asset["seconds"] > 0
        assert asset["confidence"] is None or 0 <= asset["confidence"] <= 1
    assert by_input["animals/dog.gltf"]["template"] == "quadruped"
    assert (by_input["animals/dog.gltf"]["up"], by_input["animals/dog.gltf"]["front"]) == ("z", "-y")
    assert by_input["hero.obj"]["template"] == "biped"
    bad = by_input["sub/bad.obj"]
    assert bad["status"] == "failed" and bad["error_type"] == "InputError"
    assert bad["error"].startswith("sub/bad.obj: ") and "\n" not in bad["error"]
    assert_rest_poses(by_input)


def assert_rest_poses(by_input: dict) -> None:
    """The report's rest pose of each reference asset: the T-posed hero, the A-posed kid (arms 45 degrees
    down), none for the dog (no arms) and for the broken file (no rig)."""
    hero, kid = by_input["hero.obj"], by_input["sub/deeper/kid.obj"]
    assert hero["rest_pose"] == "T" and abs(hero["arm_angle"]) < 20
    assert kid["rest_pose"] == "A" and 30 <= kid["arm_angle"] <= 55
    for rel in ("animals/dog.gltf", "sub/bad.obj"):
        assert by_input[rel]["rest_pose"] is None and by_input[rel]["arm_angle"] is None


def test_junit_report(reference):
    root = ET.parse(reference[4]).getroot()
    suite = root.find("testsuite")
    assert (suite.get("tests"), suite.get("failures"), suite.get("skipped")) == ("4", "1", "0")
    cases = {(c.get("classname"), c.get("name")): c for c in suite.iter("testcase")}
    assert set(cases) == {("animals", "dog.gltf"), (".", "hero.obj"), ("sub", "bad.obj"),
                          ("sub/deeper", "kid.obj")}
    failure = cases["sub", "bad.obj"].find("failure")
    assert failure.get("type") == "InputError" and failure.get("message").startswith("sub/bad.obj: ")
    assert cases[".", "hero.obj"].find("failure") is None
    assert ", rest pose T (" in cases[".", "hero.obj"].find("system-out").text
    assert ", rest pose A (" in cases["sub/deeper", "kid.obj"].find("system-out").text
    assert "rest pose" not in cases["animals", "dog.gltf"].find("system-out").text


def test_second_run_skips_everything(reference, tmp_path):
    assets, out = reference[:2]
    before = outputs(out)
    report = tmp_path / "again.json"
    result = run("batch", assets, "-o", out, *AXES, "--report", report, "--junit", tmp_path / "again.xml")
    # bad.obj still has no rig, so the batch still fails, without trying it again.
    assert result.exit_code == 7
    assert statuses(report) == {"animals/dog.gltf": ("skipped", "ok"), "hero.obj": ("skipped", "ok"),
                                "sub/bad.obj": ("skipped", "failed"), "sub/deeper/kid.obj": ("skipped", "ok")}
    assert all(not a["timings"] for a in json.loads(report.read_text())["assets"])
    assert_rest_poses({a["input"]: a for a in json.loads(report.read_text())["assets"]})  # kept from the first run
    assert outputs(out) == before
    assert "4 assets unchanged since the last run" in result.stderr
    suite = ET.parse(tmp_path / "again.xml").getroot().find("testsuite")
    assert (suite.get("failures"), suite.get("skipped")) == ("1", "3")


def test_exit_code_is_zero_when_nothing_failed(copy):
    assets, out = copy
    (assets / "sub" / "bad.obj").unlink()
    result = run("batch", assets, "-o", out, *AXES)
    assert result.exit_code == 0, result.output


def test_changed_broken_and_lost_assets_are_rigged_again(copy, reference, tmp_path):
    assets, out = copy
    with open(assets / "sub" / "deeper" / "kid.obj", "a") as f:
        f.write("# touched\n")  # new content, same geometry: rigged again, to the same bytes
    (assets / "hero.obj").write_text("v 0 0 0\n")  # rigged before, broken now
    (out / "animals" / "dog.rigged.glb").unlink()  # output lost
    report = tmp_path / "report.json"
    result = run("batch", assets, "-o", out, *AXES, "--report", report)
    assert result.exit_code == 7
    assert statuses(report) == {"animals/dog.gltf": ("ok", None), "hero.obj": ("failed", None),
                                "sub/bad.obj": ("skipped", "failed"), "sub/deeper/kid.obj": ("ok", None)}
    assert not (out / "hero.rigged.glb").exists()  # a stale rig of the old mesh would mislead
    old = outputs(reference[1])
    assert outputs(out) == {k: v for k, v in old.items() if k != "hero.rigged.glb"}


def test_force_rigs_everything_again_with_identical_outputs(copy, reference, tmp_path):
    assets, out = copy
    report = tmp_path / "report.json"
    result = run("batch", assets, "-o", out, *AXES, "--force", "-j", "1", "--report", report)
    assert result.exit_code == 7
    assert {s for s, _ in statuses(report).values()} == {"ok", "failed"}
    assert outputs(out) == outputs(reference[1])  # -j 1 gives what -j 2 gave


def test_slowest_assets_start_first_by_their_last_time(copy):
    assets, out = copy
    manifest_path = out / batch.MANIFEST_NAME
    manifest = json.loads(manifest_path.read_text())
    timed = manifest["assets"]
    assert all(entry["seconds"] >= 0 for entry in timed.values())   # the earlier run kept every asset's time
    # Pretend the smallest mesh was the slowest and the biggest nearly the quickest: one worker takes them in
    # that order. (The broken asset fails at once, so it goes last: outcomes that arrive together are handed
    # on in path order.)
    order = ["sub/deeper/kid.obj", "animals/dog.gltf", "hero.obj", "sub/bad.obj"]
    for rank, rel in enumerate(order):
        timed[rel]["seconds"] = 10.0 - rank
    manifest_path.write_text(json.dumps(manifest))
    finished = []
    rig_folder(assets, out, "biped", RigOptions(up="y", front="z"), jobs=1, force=True,
               on_result=lambda asset: finished.append(asset.input))
    assert finished == order


def test_cluster_gives_byte_identical_outputs(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    assets, out = reference[:2]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        result = rig_folder(assets, tmp_path / "rigged", "biped", RigOptions(up="y", front="z"),
                            scheduler=cluster.scheduler_address)
    assert result.exit_code == 7
    assert {a.input: a.status for a in result.assets} == {**{rel: "ok" for rel in RIGGED}, "sub/bad.obj": "failed"}
    assert outputs(tmp_path / "rigged") == outputs(out)


# ------------------------------------------------------------------------------------------ auto and skeletons

def test_config_skeleton_and_template_auto_rig(skeleton_reference):
    assets, out, result, report = skeleton_reference
    assert result.exit_code == 0, result.output
    by_input = {a["input"]: a for a in json.loads(report.read_text())["assets"]}
    assert {rel: (a["status"], a["template"], a["up"], a["front"]) for rel, a in by_input.items()} == {
        "crowd/extra.obj": ("ok", "skeleton rigs/studio.json", "", ""),  # up and front do not apply
        "dog.obj": ("ok", "auto", "y", "z"),
        "hero.obj": ("ok", "skeleton rigs/studio.json", "", "")}
    studio = read_skeleton(assets / "rigs" / "studio.json")
    for name in ("hero", "crowd/extra"):
        rig = read_glb(out / f"{name}.rigged.glb")
        assert rig.names == studio.names
        np.testing.assert_allclose(rig.joints, studio.positions, atol=1e-5)  # scale 1: the mesh's units
        np.testing.assert_allclose(rig.weights.sum(axis=1), 1, atol=1e-5)
        assert (rig.weights.max(axis=0) > 0.5).sum() >= 15  # the joints own their parts, not one joint all
    hero_vertices = sum(line.startswith("v ") for line in (assets / "hero.obj").read_text().splitlines())
    assert len(read_glb(out / "hero.rigged.glb").vertices) == hero_vertices
    dog = read_glb(out / "dog.rigged.glb")
    assert dog.names[0] == "root" and any(n.startswith("chain") for n in dog.names)
    np.testing.assert_allclose(dog.weights.sum(axis=1), 1, atol=1e-5)


def test_skeleton_and_auto_assets_resume_on_their_own_options(skeleton_reference, tmp_path):
    assets, out = tmp_path / "assets", tmp_path / "rigged"
    shutil.copytree(skeleton_reference[0], assets)
    shutil.copytree(skeleton_reference[1], out)
    report = tmp_path / "report.json"

    def again(*args: str, voxels: int = 32) -> dict[str, str]:
        result = run("batch", assets, "-o", out, "-j", "1", "--voxels", voxels, "--report", report, *args)
        assert result.exit_code == 0, result.output
        return {rel: status for rel, (status, _) in statuses(report).items()}

    skeleton_assets = {"crowd/extra.obj", "hero.obj"}
    assert again() == {"crowd/extra.obj": "skipped", "dog.obj": "skipped", "hero.obj": "skipped"}
    before = outputs(out)
    studio = json.loads((assets / "rigs" / "studio.json").read_text())
    studio["joints"][-1]["position"][1] += 0.01
    (assets / "rigs" / "studio.json").write_text(json.dumps(studio))
    assert again() == {"crowd/extra.obj": "ok", "dog.obj": "skipped", "hero.obj": "ok"}
    changed = outputs(out)
    assert {k for k in before if changed[k] != before[k]} == {"crowd/extra.rigged.glb", "hero.rigged.glb"}
    assert again(voxels=40) == {"crowd/extra.obj": "skipped", "dog.obj": "ok", "hero.obj": "skipped"}
    assert outputs(out)["hero.rigged.glb"] == changed["hero.rigged.glb"]
    # A JSON skeleton's default scale is 1: saying so changes nothing; auto does, for the skeleton assets only.
    assert set(again("--skeleton-scale", "1", voxels=40).values()) == {"skipped"}
    assert {rel for rel, s in again("--skeleton-scale", "auto", voxels=40).items() if s == "ok"} == skeleton_assets


def test_template_auto_from_the_command_line(tmp_path):
    (tmp_path / "in").mkdir()
    shutil.copy(DATA / "dog.obj", tmp_path / "in" / "dog.obj")
    report = tmp_path / "report.json"
    result = run("batch", tmp_path / "in", "-o", tmp_path / "out", "--template", "auto", "--voxels", "24", "-j", "1",
                 "--report", report)
    assert result.exit_code == 0, result.output
    assert [(a["status"], a["template"]) for a in json.loads(report.read_text())["assets"]] == [("ok", "auto")]
    assert read_glb(tmp_path / "out" / "dog.rigged.glb").names[0] == "root"


def test_pinocchio_with_a_multi_root_skeleton_fails_that_asset(tmp_path):
    (tmp_path / "in").mkdir()
    shutil.copy(DATA / "mannequin.obj", tmp_path / "in" / "hero.obj")
    (tmp_path / "two.json").write_text(json.dumps(TWO_ROOTS))
    result = rig_folder(tmp_path / "in", tmp_path / "out", skeleton=tmp_path / "two.json", fmt="pinocchio", jobs=1)
    [asset] = result.assets
    assert (asset.status, asset.error_type) == ("failed", "SkeletonError")
    assert asset.template == f"skeleton {tmp_path}/two.json" and asset.up == asset.front == ""
    assert asset.error.startswith("hero.obj: ") and "one root" in asset.error and "\n" not in asset.error
    assert result.exit_code == 7 and not (tmp_path / "out" / "hero.rigged").exists()


def test_cluster_rigs_skeleton_and_auto_assets(skeleton_reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    assets, out = skeleton_reference[:2]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        result = rig_folder(assets, tmp_path / "rigged", options=RigOptions(voxels=32),
                            scheduler=cluster.scheduler_address)
    assert {a.input: a.status for a in result.assets} == {"crowd/extra.obj": "ok", "dog.obj": "ok", "hero.obj": "ok"}
    assert outputs(tmp_path / "rigged") == outputs(out)  # the parsed skeleton travelled; no shared files


def test_template_and_skeleton_replace_each_other_in_the_cascade(tmp_path):
    for rel in ["a.obj", "hero.obj", "dogs/rex.obj", "dogs/big/bruno.obj", "dogs/big/max.obj"]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("v 0 0 0\n")
    (tmp_path / "rigs").mkdir()
    shutil.copy(DATA / "mannequin.joints.json", tmp_path / "rigs" / "studio.json")
    shutil.copy(DATA / "dog.joints.json", tmp_path / "rigs" / "hero.json")
    (tmp_path / "dogs" / "big" / "autorig.json").write_text(
        json.dumps({"files": {"bruno.obj": {"skeleton": "../../rigs/studio.json"}}}))
    (tmp_path / "dogs" / "autorig.toml").write_text('template = "quadruped"\n')

    def plan(template="biped", options=RigOptions(up="y", front="z"), **kwargs):
        plans = plan_assets(tmp_path, tmp_path / "out", template, options, "glb", ["obj"], **kwargs)
        return {p.rel: p for p in plans}

    # The command line's skeleton, until a config says template; a deeper skeleton again replaces that.
    got = plan(skeleton=tmp_path / "rigs" / "studio.json")
    assert {rel: (p.label, p.up, p.front) for rel, p in got.items()} == {
        "a.obj": ("skeleton rigs/studio.json", "", ""), "hero.obj": ("skeleton rigs/studio.json", "", ""),
        "dogs/rex.obj": ("quadruped", "y", "z"), "dogs/big/bruno.obj": ("skeleton rigs/studio.json", "", ""),
        "dogs/big/max.obj": ("quadruped", "y", "z")}
    assert got["a.obj"].template is None and got["a.obj"].skeleton is got["dogs/big/bruno.obj"].skeleton  # read once
    assert isinstance(got["a.obj"].options, SkinOptions) and got["a.obj"].options.scale == 1.0

    (tmp_path / "autorig.toml").write_text('skeleton = "rigs/studio.json"\n'
                                           '[files."hero.obj"]\nskeleton = "rigs/hero.json"\n'
                                           '[files."a.obj"]\ntemplate = "auto"\n')
    got = plan()
    assert {rel: p.label for rel, p in got.items()} == {
        "a.obj": "auto", "hero.obj": "skeleton rigs/hero.json", "dogs/rex.obj": "quadruped",
        "dogs/big/bruno.obj": "skeleton rigs/studio.json", "dogs/big/max.obj": "quadruped"}
    assert got["hero.obj"].skeleton.names == read_skeleton(DATA / "dog.joints.json").names
    # Keys: a skeleton asset's ignore the axes and template auto's settings; auto's ignore the scale.
    other = plan(options=RigOptions(up="x", front="z", voxels=64), skin_options=SkinOptions(scale="auto"))
    changed = {rel for rel in got if other[rel].key != got[rel].key}
    assert changed == set(got) and other["a.obj"].options.voxels == 64
    axes = plan(options=RigOptions(up="x", front="z"))
    assert {rel for rel in got if axes[rel].key != got[rel].key} == {"a.obj", "dogs/rex.obj", "dogs/big/max.obj"}
    voxels = plan(options=RigOptions(up="y", front="z", voxels=64))
    assert {rel for rel in got if voxels[rel].key != got[rel].key} == {"a.obj"}
    scale = plan(skin_options=SkinOptions(scale=2))
    assert {rel for rel in got if scale[rel].key != got[rel].key} == {"hero.obj", "dogs/big/bruno.obj"}
    with pytest.raises(InputError, match="positive number or auto"):
        rig_folder(tmp_path, tmp_path / "out", skin_options=SkinOptions(scale=-1))


def test_a_broken_skeleton_file_stops_the_batch_before_rigging(tmp_path):
    (tmp_path / "in" / "sub").mkdir(parents=True)
    shutil.copy(DATA / "mannequin.obj", tmp_path / "in" / "a.obj")
    shutil.copy(DATA / "mannequin.obj", tmp_path / "in" / "sub" / "b.obj")
    (tmp_path / "in" / "broken.json").write_text('{"joints": [{"name": "hips", "parent": "pelvis", '
                                                 '"position": [0, 1, 0]}]}')
    (tmp_path / "in" / "sub" / "autorig.toml").write_text('[files."b.obj"]\nskeleton = "../broken.json"\n')
    result = run("batch", tmp_path / "in", "-o", tmp_path / "out", "-j", "1")
    assert result.exit_code == 3, result.output
    assert len(result.stderr.splitlines()) == 1
    assert "sub/autorig.toml" in result.stderr and "broken.json" in result.stderr
    assert "unknown parent 'pelvis'" in result.stderr
    assert not list((tmp_path / "out").rglob("*.glb")) and not (tmp_path / "out" / batch.MANIFEST_NAME).exists()
    # From the folder below, the config names a file outside the input folder: refused before it is read.
    with pytest.raises(ConfigError, match="'..' leads outside the input's folder"):
        rig_folder(tmp_path / "in" / "sub", tmp_path / "out", skeleton=tmp_path / "in" / "broken.json")
    with pytest.raises(SkeletonError, match="unknown parent"):
        rig_folder(tmp_path / "in" / "sub", tmp_path / "out", skeleton=tmp_path / "in" / "broken.json",
                   options=RigOptions(allow_outside_paths=True))


# ------------------------------------------------------------------------------------------ without rigging

def test_finds_meshes_recursively_in_a_stable_order(tmp_path):
    for rel in ["b.obj", "a/z.PLY", "a-b.stl", "a/b/c.off", ".hidden/x.obj", "a/.x.obj", "notes.txt",
                "out/old.glb"]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("")
    assert find_meshes(tmp_path, exclude=tmp_path / "out") == ["a/b/c.off", "a/z.PLY", "a-b.stl", "b.obj"]
    assert find_meshes(tmp_path, ["ply", ".STL"]) == ["a/z.PLY", "a-b.stl"]
    assert BATCH_EXTENSIONS.split(",") == list(batch.DEFAULT_EXTENSIONS)


def test_nearest_config_wins_key_by_key(tmp_path):
    for rel in ["a.obj", "horse.obj", "dogs/rex.obj", "dogs/big/bruno.obj", "dogs/big/horse2.obj"]:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("v 0 0 0\n")
    (tmp_path / "autorig.toml").write_text(
        'front = "x"\n[files."horse*.obj"]\ntemplate = "horse"\nup = "Z"\n[files."dogs/*"]\ntemplate = "quadruped"\n')
    (tmp_path / "dogs" / "big" / "autorig.json").write_text(
        json.dumps({"front": "-x", "files": {"bruno.obj": {"up": "auto"}}}))
    plans = plan_assets(tmp_path, tmp_path / "out", "biped", RigOptions(up="y", front="z"), "glb",
                        batch.DEFAULT_EXTENSIONS)
    got = {p.rel: (p.template.name, p.up, p.front) for p in plans}
    assert got == {"a.obj": ("biped", "y", "x"), "horse.obj": ("horse", "z", "x"),
                   "dogs/rex.obj": ("quadruped", "y", "x"), "dogs/big/bruno.obj": ("quadruped", "auto", "-x"),
                   "dogs/big/horse2.obj": ("quadruped", "z", "-x")}  # "dogs/*" is written after "horse*.obj"


@pytest.mark.parametrize("config, error, code", [
    ('template = "biped"\ncolour = "red"\n', "unknown key 'colour'", 2),
    ('[files."a.obj"]\nup = "q"\n', "bad axis 'q'", 2),
    ('up = "y"\nfront = "-y"\n', "parallel", 2),
    ('template = \n', "autorig.toml", 2),
    ('template = "octopus"\n', "unknown template 'octopus'", 3),
    ('template = "biped"\nskeleton = "rig.json"\n', "template and skeleton are alternatives", 2),
    ('[files."a.obj"]\ntemplate = "auto"\nskeleton = "rig.json"\n', "files.'a.obj': template and skeleton", 2),
    ('skeleton = 3\n', "skeleton must be a string", 2),
    ('skeleton = "missing.json"\n', "missing.json: cannot read", 3),
    ('skeleton = "rig.fbx"\n', "unknown skeleton format '.fbx'", 3),
])
def test_config_errors_stop_the_batch_before_rigging(tmp_path, config, error, code):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.obj").write_text("v 0 0 0\n")
    (tmp_path / "in" / "autorig.toml").write_text(config)
    result = run("batch", tmp_path / "in", "-o", tmp_path / "out")
    assert result.exit_code == code, result.output
    assert error in result.stderr and len(result.stderr.splitlines()) == 1
    assert not (tmp_path / "out" / "a.rigged.glb").exists()


def test_config_template_file_is_relative_to_the_config(tmp_path):
    from autorig.template import _builtin_folder
    (tmp_path / "rigs").mkdir()
    (tmp_path / "rigs" / "mine.json").write_text(_builtin_folder().joinpath("biped.json").read_text())
    (tmp_path / "a.obj").write_text("")
    (tmp_path / "autorig.toml").write_text('template = "rigs/mine.json"\n')
    plans = plan_assets(tmp_path, tmp_path / "out", "quadruped", RigOptions(), "glb", ["obj"])
    assert plans[0].template.name == "biped"
    (tmp_path / "autorig.json").write_text("{}")
    with pytest.raises(ConfigError, match="both"):
        plan_assets(tmp_path, tmp_path / "out", "quadruped", RigOptions(), "glb", ["obj"])
    (tmp_path / "autorig.json").unlink()
    (tmp_path / "autorig.toml").write_text('template = "rigs/missing.json"\n')
    with pytest.raises(TemplateError, match="missing.json"):
        plan_assets(tmp_path, tmp_path / "out", "quadruped", RigOptions(), "glb", ["obj"])


def test_same_stem_keeps_the_extension_and_key_covers_gltf_buffers(tmp_path):
    (tmp_path / "hero.obj").write_text("")
    (tmp_path / "hero.ply").write_text("")
    (tmp_path / "dog.gltf").write_text(json.dumps({"buffers": [{"uri": "dog%20data.bin"}, {"uri": "data:,x"}]}))
    (tmp_path / "dog data.bin").write_bytes(b"1")
    plans = {p.rel: p for p in plan_assets(tmp_path, tmp_path / "out", "biped", RigOptions(), "glb",
                                           batch.DEFAULT_EXTENSIONS)}
    assert [plans["hero.obj"].output, plans["hero.ply"].output] == ["hero.obj.rigged.glb", "hero.ply.rigged.glb"]
    assert list(input_files(tmp_path / "dog.gltf")) == ["dog.gltf", "dog data.bin"]
    (tmp_path / "dog data.bin").write_bytes(b"2")
    again = {p.rel: p for p in plan_assets(tmp_path, tmp_path / "out", "biped", RigOptions(), "glb",
                                           batch.DEFAULT_EXTENSIONS)}
    assert again["dog.gltf"].key != plans["dog.gltf"].key and again["hero.obj"].key == plans["hero.obj"].key


@pytest.mark.parametrize("args, code, message", [
    (["-o", "{in}"], 2, "must not be the input folder"),
    (["-o", "{out}", "--report", "{tmp}/no/such/dir/r.json"], 4, "does not exist"),
    (["-o", "{out}", "--ext", "obj,fbx"], 2, "not fbx"),
    (["-o", "{out}", "-j", "2", "--scheduler", "tcp://127.0.0.1:1"], 2, "does not apply"),
    (["-o", "{out}", "--scheduler", "carrier-pigeon://x"], 1, "bad Dask scheduler address"),
    (["-o", "{out}", "--template", "octopus"], 3, "unknown template"),
    (["-o", "{out}", "--skeleton", "{tmp}/rig.json", "--template", "biped"], 2, "--template and --skeleton"),
    (["-o", "{out}", "--skeleton", "{tmp}/rig.json", "-t", "auto"], 2, "alternatives"),
    (["-o", "{out}", "--skeleton-scale", "0"], 2, "not a positive number or auto"),
    (["-o", "{out}", "--skeleton", "{tmp}/rig.bvh"], 3, "rig.bvh: cannot read"),
])
def test_usage_errors(tmp_path, args, code, message):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.obj").write_text("")
    names = {"in": tmp_path / "in", "out": tmp_path / "out", "tmp": tmp_path}
    result = run("batch", tmp_path / "in", *[a.format(**names) for a in args])
    assert result.exit_code == code, result.output
    assert message in result.stderr


def test_an_unreadable_asset_fails_alone(tmp_path):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "gone.obj").symlink_to(tmp_path / "nowhere.obj")
    result = rig_folder(tmp_path / "in", tmp_path / "out", jobs=1)
    assert [(a.input, a.status, a.error_type) for a in result.assets] == [("gone.obj", "failed", "InputError")]
    assert "cannot read" in result.assets[0].error and result.exit_code == 7
    # Not remembered: the file may come back.
    assert read_manifest(tmp_path / "out" / batch.MANIFEST_NAME) == {}


def test_cluster_mode_without_dask_says_how_to_install(tmp_path, monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    (tmp_path / "a.obj").write_text("")
    with pytest.raises(MissingPackageError, match=r"pip install 'autorig\[cluster\]'") as error:
        rig_folder(tmp_path, tmp_path / "out", scheduler="tcp://127.0.0.1:8786")
    assert error.value.exit_code == 9     # a missing optional package's own code, not the cluster's 1


def test_progress_bar_on_a_terminal(tmp_path):
    import io

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    progress = BatchProgress(stream=stream)
    progress.on_start(2, 1)
    progress.on_result(batch.AssetResult("a.obj", "a.rigged.glb", "ok", "biped", "y", "z", seconds=1.0))
    progress.on_result(batch.AssetResult("b.obj", "b.rigged.glb", "failed", "biped", "y", "z",
                                         error="b.obj: the mesh is flat"))
    progress.close()
    text = stream.getvalue()
    assert "1 asset unchanged" in text and "failed  b.obj: the mesh is flat" in text
    assert "2/2" in text and "ok 1, failed 1, left 0" in text


def test_junit_escapes_and_skips(tmp_path):
    assets = [batch.AssetResult("a <&>.obj", "a.glb", "skipped", "biped", "y", "z", previous="ok"),
              batch.AssetResult("b.obj", "b.glb", "skipped", "biped", "y", "z", previous="failed",
                                error='b.obj: "quoted" <x>', error_type="InputError")]
    write_junit_report(batch.BatchResult(tmp_path, tmp_path, assets, 1.0), tmp_path / "r.xml")
    cases = list(ET.parse(tmp_path / "r.xml").getroot().iter("testcase"))
    assert cases[0].get("name") == "a <&>.obj" and cases[0].find("skipped") is not None
    assert cases[1].find("failure").get("message").startswith('b.obj: "quoted" <x>')
