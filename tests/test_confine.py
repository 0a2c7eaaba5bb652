"""Files come only from the asset's own folder (issue 28): textures, MTL files and glTF images or buffers named
by an absolute path, a '..' that leaves the folder, a symlink leading out or a file: URI are refused with one
warning line naming the material and the path, the rig is still written, and the outside file's bytes are not
in it; --allow-outside-paths lets them in. Every other texture left out (missing, not an image, unsupported)
is said the same way, and recorded in the output and the batch report."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pygltflib
import pytest
from click.testing import CliRunner
from test_look import CUBE_OBJ, JPEG, PNG, cube_rig

from autorig.cli import cli

SECRET = b"SECRET-PRIVATE-BYTES-28"
PRIVATE = PNG + SECRET  # a real PNG signature: read, it would go into the rig
SKELETON = {"joints": [{"name": "root", "parent": None, "position": [0.5, 0, 0.5]},
                       {"name": "top", "parent": "root", "position": [0.5, 1, 0.5]}]}


def run(*args) -> object:
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="autorig")


@pytest.fixture
def place(tmp_path) -> Path:
    """tmp/asset/ (the asset's folder, with the cube's photo.jpg), tmp/secret/private.png, tmp/skeleton.json."""
    (tmp_path / "asset").mkdir()
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "private.png").write_bytes(PRIVATE)
    (tmp_path / "secret" / "passwd").write_text("root:x:0:0:root:/root:/bin/bash\n" + SECRET.decode())
    (tmp_path / "asset" / "photo.jpg").write_bytes(JPEG)
    (tmp_path / "skeleton.json").write_text(json.dumps(SKELETON))
    return tmp_path


def obj_asset(place: Path, painted_map: str) -> Path:
    """The cube, its material 'painted' mapping ``painted_map``."""
    (place / "asset" / "cube.mtl").write_text(f"newmtl painted\nmap_Kd {painted_map}\nnewmtl photo\n"
                                              f"map_Kd photo.jpg\nnewmtl plain\nKd 0 0.5 1\n")
    path = place / "asset" / "cube.obj"
    path.write_text(CUBE_OBJ)
    return path


def rig_it(place: Path, mesh: Path, *extra) -> tuple[object, Path]:
    out = place / "out.glb"
    return run(mesh, "--skeleton", place / "skeleton.json", "-o", out, *extra), out


def dropped_in(out: Path) -> list[dict]:
    return pygltflib.GLTF2().load(str(out)).scenes[0].extras.get("autorig_dropped", [])


def warnings_of(result) -> list[str]:
    return [line for line in result.stderr.splitlines() if line.startswith("autorig: warning: ")]


def link_or_skip(link: Path, target: Path) -> None:
    try:
        os.symlink(target, link)
    except (OSError, NotImplementedError):
        pytest.skip("no symlinks here")


# (how the MTL names the secret, a setup step, the reason the warning gives)
OBJ_CASES = {
    "absolute": (lambda p: str(p / "secret" / "private.png"), None, "an absolute path"),
    "dot-dot": (lambda p: "../secret/private.png", None, "'..' leads outside"),
    "dot-dot-inside-first": (lambda p: "sub/../../secret/private.png", None, "'..' leads outside"),
    "backslashes": (lambda p: "..\\secret\\private.png", None, "'..' leads outside"),
    "symlinked-file": (lambda p: "skin.png",
                       lambda p: link_or_skip(p / "asset" / "skin.png", p / "secret" / "private.png"),
                       "a symlink leads outside"),
    "symlinked-folder": (lambda p: "textures/private.png",
                         lambda p: link_or_skip(p / "asset" / "textures", p / "secret"), "a symlink leads outside"),
    "etc-passwd-like": (lambda p: str(p / "secret" / "passwd"), None, "an absolute path"),
}


def refused_and_rigged(place: Path, case: tuple, asset, what: str) -> None:
    """Rig ``asset(place, path)`` with the path of ``case`` (how it is written, a setup step, the reason the
    warning gives): one warning naming ``what`` and the path, the rig written, the secret not in it, the
    photo inside the folder still in it, and the output's extras recording it."""
    written, setup, reason = case
    if setup:
        setup(place)
    mesh = asset(place, written(place))
    result, out = rig_it(place, mesh)
    assert result.exit_code == 0, result.stderr
    [warning] = warnings_of(result)
    assert f"{what}: {written(place)}: {reason}" in warning
    assert warning.startswith(f"autorig: warning: {mesh}: ") and warning.endswith("; left out")
    data = out.read_bytes()
    assert SECRET not in data and JPEG in data
    [dropped] = dropped_in(out)
    assert dropped["what"] == what and dropped["path"] == written(place) and reason in dropped["reason"]


@pytest.mark.parametrize("case", OBJ_CASES)
def test_an_mtl_map_outside_the_asset_is_refused_and_the_rig_still_written(place, case):
    refused_and_rigged(place, OBJ_CASES[case], obj_asset, "material 'painted' map_Kd")


def test_allow_outside_paths_reads_them(place):
    mesh = obj_asset(place, "../secret/private.png")
    result, out = rig_it(place, mesh, "--allow-outside-paths")
    assert result.exit_code == 0 and warnings_of(result) == []
    assert PRIVATE in out.read_bytes() and dropped_in(out) == []


@pytest.mark.parametrize("name, content, reason", [
    ("passwd.png", b"root:x:0:0:root:/root:/bin/bash\n", "not an image"),
    ("skin.bmp", b"BM" + bytes(60), "unsupported image format (BMP"),
    ("skin.tga", bytes(40), "unsupported image format (TGA"),
    ("gone.png", None, "missing file"),
])
def test_every_texture_left_out_is_said(place, name, content, reason):
    if content is not None:
        (place / "asset" / name).write_bytes(content)
    result, out = rig_it(place, obj_asset(place, name))
    assert result.exit_code == 0
    [warning] = warnings_of(result)
    assert f"map_Kd: {name}: {reason}" in warning
    assert dropped_in(out)[0]["path"] == name and reason in dropped_in(out)[0]["reason"]


def test_etc_passwd_allowed_is_still_not_an_image(place):
    result, out = rig_it(place, obj_asset(place, str(place / "secret" / "passwd")), "--allow-outside-paths")
    assert result.exit_code == 0 and "not an image" in warnings_of(result)[0]
    assert SECRET not in out.read_bytes()


def test_an_mtl_library_outside_is_refused(place):
    (place / "secret" / "evil.mtl").write_text("newmtl painted\nmap_Kd private.png\n")
    mesh = place / "asset" / "cube.obj"
    mesh.write_text(CUBE_OBJ.replace("mtllib cube.mtl", "mtllib ../secret/evil.mtl"))
    result, out = rig_it(place, mesh)
    assert result.exit_code == 0 and "mtllib: ../secret/evil.mtl: '..' leads outside" in warnings_of(result)[0]
    assert SECRET not in out.read_bytes()


def test_an_ordinary_asset_says_nothing_and_records_nothing(place):
    (place / "asset" / "textures").mkdir()
    (place / "asset" / "textures" / "paint.png").write_bytes(PNG)
    result, out = rig_it(place, obj_asset(place, "textures/paint.png"))
    assert result.exit_code == 0 and result.stderr == ""
    extras = pygltflib.GLTF2().load(str(out)).scenes[0].extras
    assert "autorig_dropped" not in extras


def gltf_asset(place: Path, image_uri: str) -> Path:
    """The cube rigged and written as a .gltf in the asset's folder, its first image (the PNG) at ``image_uri``."""
    from autorig.exchange.gltf import gltf_bytes
    (place / "asset" / "textures").mkdir(exist_ok=True)
    (place / "asset" / "textures" / "paint.png").write_bytes(PNG)
    document = json.loads(gltf_bytes(cube_rig(obj_asset(place, "textures/paint.png"))))
    document["images"][0] = {"uri": image_uri}
    path = place / "asset" / "cube.gltf"
    path.write_text(json.dumps(document))
    return path


GLTF_CASES = {
    "absolute": (lambda p: str(p / "secret" / "private.png"), None, "an absolute path"),
    "dot-dot": (lambda p: "../secret/private.png", None, "'..' leads outside"),
    "percent-escaped-dot-dot": (lambda p: "%2E%2E/secret/private.png", None, "'..' leads outside"),
    "file-uri": (lambda p: (p / "secret" / "private.png").as_uri(), None, "a file: URI"),
    "symlinked-file": (lambda p: "skin.png",
                       lambda p: link_or_skip(p / "asset" / "skin.png", p / "secret" / "private.png"),
                       "a symlink leads outside"),
    "http": (lambda p: "http://example.com/private.png", None, "a http: URI; autorig reads only files"),
    "not-an-image": (lambda p: "cube.obj", None, "not an image"),
}


@pytest.mark.parametrize("case", GLTF_CASES)
def test_a_gltf_image_uri_outside_the_asset_is_refused_and_the_rig_still_written(place, case):
    refused_and_rigged(place, GLTF_CASES[case], gltf_asset, "image 0")


def test_a_file_uri_is_read_when_allowed(place):
    mesh = gltf_asset(place, (place / "secret" / "private.png").as_uri())
    result, out = rig_it(place, mesh, "--allow-outside-paths")
    assert result.exit_code == 0 and PRIVATE in out.read_bytes()


def test_a_gltf_buffer_outside_the_asset_stops_with_one_line(place):
    mesh = gltf_asset(place, "textures/paint.png")
    document = json.loads(mesh.read_text())
    blob = pygltflib.GLTF2().load(str(mesh)).buffers[0].uri
    import base64
    (place / "secret" / "cube.bin").write_bytes(base64.b64decode(blob.split(",", 1)[1]))
    document["buffers"][0]["uri"] = "../secret/cube.bin"
    mesh.write_text(json.dumps(document))
    result, out = rig_it(place, mesh)
    assert result.exit_code == 2 and not out.exists()
    [line] = result.stderr.splitlines()
    assert line.startswith("autorig: error: ") and "buffer ../secret/cube.bin: '..' leads outside" in line
    assert run(mesh, "--skeleton", place / "skeleton.json", "-o", out, "--allow-outside-paths").exit_code == 0


def test_batch_refuses_the_same_and_says_so_in_its_report(place):
    root = place / "in"
    (root / "a").mkdir(parents=True)
    (root / "a" / "cube.obj").write_text(CUBE_OBJ)
    (root / "a" / "cube.mtl").write_text("newmtl painted\nmap_Kd ../../secret/private.png\n")
    link_or_skip(root / "outside.obj", place / "secret" / "elsewhere.obj")
    (place / "secret" / "elsewhere.obj").write_text(CUBE_OBJ.replace("mtllib cube.mtl\n", ""))
    report = place / "report.json"
    result = run("batch", root, "-o", place / "out", "--skeleton", place / "skeleton.json", "-j", "1",
                 "--report", report)
    assert result.exit_code == 7, result.stderr
    assets = {a["input"]: a for a in json.loads(report.read_text())["assets"]}
    assert assets["a/cube.obj"]["status"] == "ok"
    assert assets["a/cube.obj"]["dropped"][0]["path"] == "../../secret/private.png"
    assert "warning a/cube.obj: material 'painted' map_Kd: ../../secret/private.png: '..' leads outside" in \
        result.stderr
    assert assets["outside.obj"]["status"] == "failed"
    assert "a symlink leads outside the input folder" in assets["outside.obj"]["error"]
    assert not (place / "out" / "outside.rigged.glb").exists()
    assert SECRET not in (place / "out" / "a" / "cube.rigged.glb").read_bytes()


def test_batch_configs_may_not_name_files_outside_the_input_folder(place):
    root = place / "in"
    root.mkdir()
    (root / "cube.obj").write_text(CUBE_OBJ)
    (root / "autorig.toml").write_text(f'skeleton = "{place / "skeleton.json"}"\n')
    result = run("batch", root, "-o", place / "out")
    assert result.exit_code == 2 and "skeleton" in result.stderr and "an absolute path" in result.stderr
    (root / "autorig.toml").write_text('html = "../../review.html"\n')
    result = run("batch", root, "-o", place / "out")
    assert result.exit_code == 2 and "html" in result.stderr and len(result.stderr.splitlines()) == 1


@pytest.mark.parametrize("suffix", [".glb", ".usdz"])
def test_an_output_over_a_symlink_replaces_the_link_not_its_target(place, suffix):
    if suffix == ".usdz":
        pytest.importorskip("pxr")
    target = place / "secret" / "precious.txt"
    target.write_bytes(SECRET)
    out = place / f"out{suffix}"
    link_or_skip(out, target)
    result = run(obj_asset(place, "photo.jpg"), "--skeleton", place / "skeleton.json", "-o", out)
    assert result.exit_code == 0, result.stderr
    assert target.read_bytes() == SECRET and not out.is_symlink() and out.stat().st_size > 1000
