"""The guide cannot rot: every example block marked ``<!-- runnable -->`` in README.md and docs/ runs, the README's
quick start rigs, the README stays a front page, and the site builds with ``mkdocs build --strict``.

The examples run in one folder holding the files they name: ``hero.obj`` and ``upload.obj`` (the project's
mannequin), ``dog.obj`` and ``dog.ply``, ``scan.obj`` (the mannequin turned Z-up, facing -y), ``joints.json``,
``hero.glb`` and ``hero.markers.json`` (its rig's wrists and knees), ``my_rig.glb``, ``man.rigged.glb``, ``studio_rig.glb``, ``walk.bvh`` and ``clip.bvh`` (121 frames),
``map.json``, ``pig.obj`` with its ``pig.mtl``, ``octopus.obj`` and ``spider.obj`` (stars of 8 and 6 arms), folders
``assets/``, ``creatures/`` and ``crowd/`` to rig and ``studio/`` of rigged characters to learn from.
``autorig`` there is this checkout's (``python -m autorig.cli``), whatever is installed.
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from rig_samples import mannequin_bvh

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
BLOCK = re.compile(r"^<!-- runnable -->\n```(bash|python)\n(.*?)^```", re.M | re.S)


def _examples() -> list:
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in BLOCK.finditer(text):
            line = text[:match.start()].count("\n") + 2
            found.append(pytest.param(match[1], match[2], id=f"{page.relative_to(ROOT)}:{line}"))
    return found


EXAMPLES = _examples()


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> tuple[Path, dict]:
    import autorig
    from autorig.exchange import write_rig
    from autorig.exchange.obj import write_obj
    from autorig.extract.shapes import star
    from autorig.samples import mannequin

    folder = tmp_path_factory.mktemp("guide")
    shutil.copy(ROOT / "data" / "mannequin.obj", folder / "hero.obj")
    shutil.copy(ROOT / "data" / "mannequin.obj", folder / "upload.obj")
    shutil.copy(ROOT / "data" / "dog.obj", folder / "dog.obj")
    shutil.copy(ROOT / "data" / "mannequin.joints.json", folder / "joints.json")
    dog = trimesh.load(folder / "dog.obj", process=False)
    dog.export(folder / "dog.ply")
    hero = trimesh.load(folder / "hero.obj", process=False)
    # Z up, facing -y: x stays, the old up (y) becomes z, the old front (z) becomes -y.
    hero.vertices = np.column_stack([hero.vertices[:, 0], -hero.vertices[:, 2], hero.vertices[:, 1]])
    hero.export(folder / "scan.obj")
    rig = autorig.rig(folder / "hero.obj")
    write_rig(rig, folder / "hero.glb", "glb")
    at = dict(zip(rig.names, rig.joints.tolist()))    # the fix-a-rig loop's markers: the hero's own joints
    (folder / "hero.markers.json").write_text(json.dumps({n: at[n] for n in ("left_wrist", "right_wrist",
                                                                             "left_knee", "right_knee")}))
    write_rig(rig, folder / "my_rig.glb", "glb")
    # 121 frames (--frame 120): the left arm lowered and raised, walking forward 2 cm a frame.
    frames = [{"left_shoulder": (0.0, 0.0, -40.0 * np.sin(k / 10)), "right_elbow": (0.0, -30.0, 0.0)}
              for k in range(121)]
    (folder / "walk.bvh").write_text(mannequin_bvh(frames, [(0, 0, 0.02 * k) for k in range(121)]))
    shutil.copy(folder / "walk.bvh", folder / "clip.bvh")
    (folder / "map.json").write_text('{"left_elbow": null}\n')
    shutil.copy(folder / "hero.glb", folder / "man.rigged.glb")
    shutil.copy(folder / "hero.glb", folder / "studio_rig.glb")
    # A textured-looking four-legged pig (the dog with a material), and two creatures no template fits.
    (folder / "pig.mtl").write_text("newmtl skin\nKd 0.9 0.6 0.6\n")
    (folder / "pig.obj").write_text("mtllib pig.mtl\nusemtl skin\n" + (folder / "dog.obj").read_text())
    for name, arms in (("octopus", 8), ("spider", 6)):
        shape = star(arms, resolution=40)
        write_obj(shape.vertices, shape.faces, folder / f"{name}.obj")
    (folder / "creatures").mkdir()
    shutil.copy(folder / "octopus.obj", folder / "creatures" / "octopus.obj")
    (folder / "crowd").mkdir()
    shutil.copy(folder / "hero.obj", folder / "crowd" / "extra.obj")
    (folder / "assets" / "sub").mkdir(parents=True)
    shutil.copy(folder / "hero.obj", folder / "assets" / "hero.obj")
    shutil.copy(folder / "dog.obj", folder / "assets" / "sub" / "dog.obj")
    (folder / "studio").mkdir()
    for pose, proportions in (("t", "adult"), ("a", "heavy")):
        sample = mannequin(pose=pose, proportions=proportions, resolution=56)
        write_rig(autorig.rig((sample.vertices, sample.faces)), folder / "studio" / f"hero_{pose}.glb", "glb")
    # ``autorig`` is this checkout's, run by this interpreter.
    bin_dir = tmp_path_factory.mktemp("bin")
    (bin_dir / "autorig").write_text(f'#!/bin/sh\nexec "{sys.executable}" -m autorig.cli "$@"\n')
    (bin_dir / "autorig").chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    return folder, env


def test_the_guide_has_runnable_examples():
    pages = {param.id.split(":")[0] for param in EXAMPLES}
    assert "README.md" in pages and len(pages) >= 6, pages


@pytest.mark.parametrize("language, code", EXAMPLES)
def test_every_runnable_example_runs(workspace, language, code):
    folder, env = workspace
    command = ["bash", "-e", "-o", "pipefail", "-c", code] if language == "bash" else [sys.executable, "-c", code]
    run = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"{code}\n--- stdout\n{run.stdout}\n--- stderr\n{run.stderr}"
    assert "Traceback" not in run.stderr


def test_the_readme_quick_start_rigs(workspace, tmp_path):
    """The quick start's first line, after its ``pip install .`` (CI installs the project as the README says)."""
    _, env = workspace
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme.split("## Quick start", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    first = block.splitlines()[0].split("#", 1)[0]
    assert first.startswith("pip install . && ")
    shutil.copytree(ROOT / "data", tmp_path / "data", ignore=shutil.ignore_patterns("corpus", "*.rigged.*"))
    run = subprocess.run(["bash", "-e", "-c", first.removeprefix("pip install . && ")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "data" / "mannequin.rigged.glb").stat().st_size > 0


def test_the_readme_is_a_front_page():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) < 150
    for section in ("## Install", "## Quick start", "## Commands", "## Exit codes", "## The guide"):
        assert section in readme
    # Each page the README points to is there.
    for target in re.findall(r"\]\(((?:docs/)?[\w/.-]+\.(?:md|png))\)", readme):
        assert (ROOT / target).is_file(), target


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None, reason="the docs extra is not installed")
def test_the_guide_builds_with_no_warnings(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for option in ("--template", "--max-segments", "--html", "--frame", "--learn"):
        assert option in cli, option
    assert "rig_folder" in (tmp_path / "site" / "reference" / "python" / "index.html").read_text(encoding="utf-8")
