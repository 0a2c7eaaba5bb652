"""The command line: help, version, templates, the default command, and one clean error line per failure.

Rigging itself is replaced by a fake where a test needs a successful rig (``fake_rig``): these tests are about
the command line, and end-to-end rigging is tested with the pipeline.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import autorig
from autorig import pipeline
from autorig.cli import FORMATS, cli
from autorig.errors import RigFailedError
from autorig.result import Rig

TETRA_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
POINT_CLOUD_PLY = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                   "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n")
WOODY_LIKE_OBJ = "v 0 0 0\nv 1 0 0\nv 1 2 0\nv 0 2 0\nv 0.5 1 0\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n"


def run(*args: str):
    return CliRunner().invoke(cli, list(args), prog_name="autorig")


def assert_one_error_line(result, code: int | None = None):
    assert result.exit_code != 0
    if code is not None:
        assert result.exit_code == code, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("autorig: error: "), lines[0]
    assert "Traceback" not in result.output
    assert result.stdout == ""


@pytest.fixture
def fake_rig(monkeypatch):
    """Replace the pipeline with a quick fake that loads the mesh for real and returns a trivial rig.
    The calls are recorded in the returned list as (mesh, template, options)."""
    from autorig.input.mesh import load_mesh

    calls = []

    def rig(mesh, template="biped", options=None):
        calls.append((mesh, template, options))
        V, F = load_mesh(mesh)
        J = len(template.names)
        return Rig(names=list(template.names), parents=template.parents.copy(), joints=template.positions.copy(),
                   weights=np.full((len(V), J), 1.0 / J), vertices=V, faces=F, template=template.name,
                   timings={"load": 0.01, "embedding": 0.25},
                   info={"up": options.up, "front": options.front, "axes_detected": "auto" in (options.up, options.front),
                         "confidence": 0.9, "confidence_parts": {"fit": 0.9}})

    monkeypatch.setattr(pipeline, "rig", rig)
    return calls


@pytest.fixture
def tetra(tmp_path) -> Path:
    path = tmp_path / "hero.obj"
    path.write_text(TETRA_OBJ)
    return path


# --------------------------------------------------------------------------------------------- help and version

def test_help_lists_subcommands_and_exit_codes():
    result = run("--help")
    assert result.exit_code == 0
    assert "autorig MESH [OPTIONS]" in result.stdout
    for word in ("rig", "templates", "Exit codes", "70", "130"):
        assert word in result.stdout
    assert run("-h").stdout == result.stdout


def test_rig_help_lists_its_options():
    result = run("rig", "--help")
    assert result.exit_code == 0
    for option in ("--template", "--output", "--format", "--up", "--front", "--verbose", "--quiet", "--debug",
                   "--version", "glb", "pinocchio", "json", "Exit codes"):
        assert option in result.stdout
    assert run("hero.obj", "--help").stdout == result.stdout  # the default command's help


def test_version():
    for args in (["--version"], ["rig", "--version"], ["hero.obj", "--version"]):
        result = run(*args)
        assert result.exit_code == 0
        assert result.stdout.strip() == f"autorig {autorig.__version__}"


def test_no_arguments_shows_usage():
    result = run()
    assert result.exit_code == 2
    assert result.stderr.startswith("Usage: autorig MESH [OPTIONS]\n   or: autorig COMMAND [ARGS]...")


def test_startup_imports_nothing_heavy():
    """--help and --version must start fast: no numpy, trimesh, scipy or libigl behind them."""
    script = ("import sys\nfrom autorig.cli import cli\n"
              "for args in (['--help'], ['--version'], ['rig', '--help']):\n"
              "    cli.main(args, prog_name='autorig', standalone_mode=False)\n"
              "heavy = {'numpy', 'trimesh', 'scipy', 'igl', 'autorig.pipeline'} & set(sys.modules)\n"
              "print('HEAVY', sorted(heavy))\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert "HEAVY []" in out


def test_rig_leaves_the_garbage_collector_on(tmp_path):
    """The CLI loads the libraries with the collector paused: a rig must leave it on, still freeing cycles."""
    from autorig.exchange.obj import write_obj
    from autorig.samples import mannequin
    sample = mannequin(pose="a")
    write_obj(sample.vertices, sample.faces, tmp_path / "hero.obj")
    script = ("import gc, sys\nfrom autorig.cli import cli\n"
              "cli.main([sys.argv[1], '-o', sys.argv[2], '-q'], prog_name='autorig', standalone_mode=False)\n"
              "class Node:\n    pass\n"
              "node = Node(); node.me = node; del node\n"
              "print('ENABLED', gc.isenabled(), 'FREED', gc.collect() > 0)\n")
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "hero.obj"), str(tmp_path / "hero.glb")],
                         capture_output=True, text=True, check=True).stdout
    assert "ENABLED True FREED True" in out
    assert (tmp_path / "hero.glb").stat().st_size > 0


def test_formats_match_the_writers():
    from autorig.exchange import FORMATS as WRITER_FORMATS
    assert list(FORMATS) == list(WRITER_FORMATS)


def test_templates_lists_the_builtins():
    result = run("templates")
    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    names = [line.split()[0] for line in lines]
    for name in ("biped", "quadruped", "horse", "centaur"):
        assert name in names
    biped = lines[names.index("biped")]
    assert "24 joints" in biped and "Human" in biped


# --------------------------------------------------------------------------------------------- rigging (faked)

def test_default_command_and_summary_line(tmp_path, tetra, fake_rig):
    result = run(str(tetra), "--template", "quadruped", "-o", str(tmp_path / "out.json"))
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    lines = result.stdout.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"{tetra}: quadruped, 28 joints (22 + 6 tips), 4 input vertices, ")
    assert lines[0].endswith(f" s -> {tmp_path / 'out.json'}")
    assert json.loads((tmp_path / "out.json").read_text())
    mesh, template, options = fake_rig[0]
    assert Path(mesh) == tetra and template.name == "quadruped"
    assert (options.up, options.front) == ("auto", "auto")


def test_rig_subcommand_default_output_and_axes(tmp_path, tetra, fake_rig):
    result = run("rig", str(tetra), "--up", "Z", "--front", "-x")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "hero.rigged.glb").is_file()
    assert result.stdout.strip().endswith("-> " + str(tmp_path / "hero.rigged.glb"))
    options = fake_rig[0][2]
    assert (options.up, options.front) == ("z", "-x")


@pytest.mark.parametrize("output,expected", [("o.json", "o.json"), ("o.gltf", "o.gltf"), ("folder", "folder")])
def test_format_from_output_extension(tmp_path, tetra, fake_rig, output, expected):
    result = run(str(tetra), "-o", str(tmp_path / output))
    assert result.exit_code == 0, result.output
    assert (tmp_path / expected).exists()
    if output == "folder":
        assert (tmp_path / "folder" / "skeleton.out").is_file()


def test_explicit_format_wins(tmp_path, tetra, fake_rig):
    result = run(str(tetra), "--format", "json", "-o", str(tmp_path / "rig.txt"))
    assert result.exit_code == 0, result.output
    assert json.loads((tmp_path / "rig.txt").read_text())


def test_verbose_prints_stage_timings_on_stderr(tmp_path, tetra, fake_rig):
    result = run(str(tetra), "-v", "-o", str(tmp_path / "out.json"))
    assert result.exit_code == 0, result.output
    assert len(result.stdout.splitlines()) == 1
    stages = [line.split()[0] for line in result.stderr.splitlines()]
    assert stages == ["load", "embedding", "write"]


def test_quiet_prints_nothing(tmp_path, tetra, fake_rig):
    result = run(str(tetra), "-q", "-o", str(tmp_path / "out.json"))
    assert result.exit_code == 0 and result.output == ""
    assert (tmp_path / "out.json").is_file()


def test_verbose_and_quiet_conflict(tetra, fake_rig):
    result = run(str(tetra), "-v", "-q")
    assert result.exit_code == 2 and "cannot be used together" in result.stderr


# ------------------------------------------------------------------------------------------------- bad input

def malformed_template(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"name": "broken", "joints": [')
    return ["--template", str(path)]


BAD_RUNS = {
    # case: (mesh file name, its content (None: no file), extra arguments, exit code, words in the message)
    "missing file": ("nothere.obj", None, [], 2, "no such file"),
    "unknown extension": ("hero.xyz", TETRA_OBJ, [], 2, "unknown mesh format"),
    "text file named .obj": ("notes.obj", "Shopping list:\nmilk\neggs\n", [], 2, "not an OBJ file"),
    "binary file named .obj": ("image.obj", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(300), [], 2,
                               "binary data"),
    "point cloud PLY": ("cloud.ply", POINT_CLOUD_PLY, [], 2, "point cloud"),
    "empty OBJ": ("empty.obj", "", [], 2, "no vertices"),
    "NaN coordinates": ("nan.obj", TETRA_OBJ.replace("v 0 1 0", "v 0 nan 0"), [], 2, "NaN"),
    "flat mesh": ("woody.obj", WOODY_LIKE_OBJ, [], 2, "flat"),
    "up parallel to front": ("hero.obj", TETRA_OBJ, ["--up", "z", "--front", "-z"], 2, "parallel"),
    "unknown template": ("hero.obj", TETRA_OBJ, ["--template", "octopus"], 3, "unknown template 'octopus'"),
    "missing template file": ("hero.obj", TETRA_OBJ, ["--template", "nope.json"], 3, "not found"),
    "malformed template": ("hero.obj", TETRA_OBJ, malformed_template, 3, "not valid JSON"),
    "missing output directory": ("hero.obj", TETRA_OBJ, ["-o", "{tmp}/no/such/dir/out.glb"], 4, "does not exist"),
    "output directory is a file": ("hero.obj", TETRA_OBJ, ["-o", "{tmp}/hero.obj/out.glb"], 4, "not a directory"),
    "output is the input": ("hero.glb", b"glTF", ["-o", "{tmp}/hero.glb"], 4, "overwrite the input"),
    "output is the input, spelled differently": ("hero.obj", TETRA_OBJ, ["-o", "{tmp}/./hero.obj"], 4,
                                                 "overwrite the input"),
    "output folder holds the input": ("hero.obj", TETRA_OBJ, ["-o", "{tmp}", "--format", "pinocchio"], 4,
                                      "overwrite the input"),
    "output is a directory": ("hero.obj", TETRA_OBJ, ["-o", "{tmp}/sub.json"], 4, "is a directory"),
}


@pytest.mark.parametrize("case", list(BAD_RUNS))
def test_bad_runs_give_one_error_line_and_no_output(tmp_path, case):
    name, content, extra, code, words = BAD_RUNS[case]
    mesh = tmp_path / name
    if isinstance(content, bytes):
        mesh.write_bytes(content)
    elif content is not None:
        mesh.write_text(content)
    (tmp_path / "sub.json").mkdir()
    extra = extra(tmp_path) if callable(extra) else [a.replace("{tmp}", str(tmp_path)) for a in extra]
    before = {p.name: (p.read_bytes() if p.is_file() else None) for p in tmp_path.iterdir()}

    result = run(str(mesh), *extra)

    assert_one_error_line(result, code)
    assert words in result.stderr, result.stderr
    after = {p.name: (p.read_bytes() if p.is_file() else None) for p in tmp_path.iterdir()}
    assert after == before, "the failed run created or changed files"
    assert list((tmp_path / "sub.json").iterdir()) == []


def test_unwritable_output_directory(tmp_path, tetra):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if (locked / "probe").exists() or _can_write(locked):
            pytest.skip("running as a user who can write anywhere (root)")
        result = run(str(tetra), "-o", str(locked / "out.glb"))
        assert_one_error_line(result, 4)
        assert "permission denied" in result.stderr
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o700)


def _can_write(folder: Path) -> bool:
    try:
        (folder / "probe").write_text("")
    except OSError:
        return False
    (folder / "probe").unlink()
    return True


def test_unknown_output_extension_is_a_usage_error(tmp_path, tetra):
    result = run(str(tetra), "-o", str(tmp_path / "out.abc"))
    assert result.exit_code == 2
    assert "--format" in result.stderr and "Traceback" not in result.output


def test_bad_axis_is_a_usage_error(tetra):
    result = run(str(tetra), "--up", "w")
    assert result.exit_code == 2 and "Invalid value for '--up'" in result.stderr


# ------------------------------------------------------------------------------------- failures inside rigging

def failing_rig(error: BaseException):
    def rig(mesh, template="biped", options=None):
        raise error
    return rig


def test_rig_failure_exit_code(tmp_path, tetra, monkeypatch):
    monkeypatch.setattr(pipeline, "rig", failing_rig(RigFailedError("the template does not fit this shape")))
    result = run(str(tetra))
    assert_one_error_line(result, 5)
    assert "does not fit" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hero.obj"]


def test_internal_error_is_one_line_with_exit_70(tetra, monkeypatch):
    monkeypatch.setattr(pipeline, "rig", failing_rig(ZeroDivisionError("division by zero\nsecond line")))
    result = run(str(tetra))
    assert result.exit_code == 70
    assert result.stderr.splitlines() == [
        "autorig: internal error: ZeroDivisionError: division by zero second line (run with --debug for details)"]


def test_debug_shows_the_traceback(tetra, monkeypatch):
    monkeypatch.setattr(pipeline, "rig", failing_rig(ZeroDivisionError("division by zero")))
    result = run(str(tetra), "--debug")
    assert result.exit_code == 70
    assert "Traceback" in result.stderr
    assert result.stderr.splitlines()[-1] == "autorig: internal error: ZeroDivisionError: division by zero"
    result = run("--debug", str(tetra), "--template", "nope")
    assert result.exit_code == 3 and "Traceback" in result.stderr


def test_ctrl_c_exits_130_with_one_line(tmp_path, tetra, monkeypatch):
    monkeypatch.setattr(pipeline, "rig", failing_rig(KeyboardInterrupt()))
    result = run(str(tetra))
    assert result.exit_code == 130
    assert result.stderr.splitlines() == ["autorig: interrupted"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hero.obj"]


def test_library_warnings_stay_off_stderr(tmp_path, tetra, monkeypatch):
    import logging
    import warnings

    def noisy(mesh, template="biped", options=None):
        warnings.warn("numpy is unhappy", RuntimeWarning)
        logging.getLogger("trimesh").warning("trimesh is unhappy")
        raise RigFailedError("no rig")

    monkeypatch.setattr(pipeline, "rig", noisy)
    assert_one_error_line(run(str(tetra)), 5)
    assert logging.root.manager.disable == logging.NOTSET  # restored after the command


# ------------------------------------------------------------------------------------------- the real program

def test_installed_entry_point_reports_errors_in_one_line(tmp_path):
    """Through a real process: the console entry point, exit code, no traceback."""
    text = tmp_path / "notes.obj"
    text.write_text("not a mesh\n")
    proc = subprocess.run([sys.executable, "-c", "from autorig.cli import main; main()", str(text)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [f"autorig: error: {text}: not an OBJ file (no OBJ statements such as "
                                        f"'v' or 'f' found)"]
    assert proc.stdout == ""
