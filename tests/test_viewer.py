"""The review page's 3D view (autorig.show.viewer) in headless Chromium: it draws each rig, moves it, colours a
joint's weights, and a scripted reviewer places markers by clicking and downloads the markers file, in the input
file's own coordinates.

One batch of two small mannequins is rigged once per module: ``hero.obj`` (y up, metres) and ``zup.obj``, the same
body stood on z, facing -y, in centimetres and moved off the origin: the view turns it upright, and the markers must
come back in its own axes and units.
"""
from __future__ import annotations

import base64
import hashlib
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from chromium import EXECUTABLE, Chromium
from click.testing import CliRunner

from autorig import samples
from autorig.cli import cli
from autorig.exchange.gltf import read_glb
from autorig.input.mesh import frame_rotation, load_mesh
from autorig.markers import accepted_names, check_markers, marker_names, read_markers
from autorig.show import viewer

pytest.importorskip("PIL", reason="the preview extra (Pillow) is not installed")
from PIL import Image  # noqa: E402

needs_chromium = pytest.mark.skipif(EXECUTABLE is None, reason="chromium is not installed (apt-get install chromium)")
ROOT = Path(__file__).resolve().parent.parent
# zup.obj = hero.obj turned (y up, z front -> z up, -y front), in centimetres, moved off the origin.
TURN = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
OFFSET = np.array([30.0, -12.0, 5.0])
MESH = np.array([0x8f, 0xa8, 0xc8])     # viewer.js's colours: the mesh's (lit: a share of it) and the bones'
BONE = np.array([0xff, 0x7f, 0x00])


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist()]
    path.write_text("".join(lines + [f"f {a} {b} {c}\n" for a, b, c in (faces + 1).tolist()]))


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """(input folder, output folder, page) of the two mannequins rigged with --html."""
    root = tmp_path_factory.mktemp("viewer")
    assets = root / "assets"
    hero = samples.mannequin(pose="a", resolution=56)
    write_obj(assets / "hero.obj", hero.vertices, hero.faces)
    write_obj(assets / "zup.obj", 100 * hero.vertices @ TURN.T + OFFSET, hero.faces)
    (assets / "autorig.toml").write_text('[files."zup.obj"]\nup = "z"\nfront = "-y"\n')
    out = root / "rigged"
    page = out / "review.html"
    result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(out), "-j", "2", "--html", str(page),
                                      "--report", str(out / "report.json")])
    assert result.exit_code == 0, result.output
    return assets, out, page


def views_of(page: Path) -> list:
    text = page.read_text(encoding="utf-8")
    start = text.index('<script type="application/json" id="views">') + len('<script type="application/json" id="views">')
    return json.loads(text[start:text.index("</script>", start)])


def test_page_data_records_the_turn_back_to_the_input(batch):
    assets, out, page = batch
    views = {v["name"]: v for v in views_of(page) if v}
    assert set(views) == {"hero.obj", "zup.obj"}
    zup = views["zup.obj"]
    frame = np.array(zup["frame"])
    assert np.array_equal(frame, frame_rotation("z", "-y")) and np.allclose(frame @ frame.T, np.eye(3))
    assert np.array_equal(np.array(views["hero.obj"]["frame"]), np.eye(3))
    # The view shows frame . p: the input's up is the view's up (y) and its front faces the camera (z).
    assert np.array_equal(frame @ [0, 0, 1], [0, 1, 0]) and np.array_equal(frame @ [0, -1, 0], [0, 0, 1])
    # The .glb keeps the input's vertices as they are (axes, units, offset; float32): nothing else to undo.
    rig = read_glb(out / "zup.rigged.glb")
    vertices, _ = load_mesh(assets / "zup.obj")
    assert np.allclose(rig.vertices, vertices, atol=1e-4, rtol=0)
    # The rigs are inlined (a small batch), byte for byte, and the markers are the biped's.
    text = page.read_text(encoding="utf-8")
    blob = text[text.index(f'id="{zup["inline"]}">') + len(f'id="{zup["inline"]}">'):]
    assert base64.b64decode(blob[:blob.index("<")]) == (out / "zup.rigged.glb").read_bytes()
    assert zup["markers"] == marker_names("biped") and set(zup["surface"]) == {"chin", "groin"}
    assert zup["joints"] == [n for n in accepted_names("biped") if n not in zup["markers"]]
    assert zup["markers_file"] == "zup.markers.json" and zup["given"] == {}


def test_three_is_beside_the_page_once_and_as_pinned(batch, tmp_path):
    assets, out, page = batch
    sys.path.insert(0, str(ROOT / "data"))
    try:
        import vendor_three
    finally:
        sys.path.remove(str(ROOT / "data"))
    shipped = out / viewer.THREE_FILE
    assert hashlib.sha256(shipped.read_bytes()).hexdigest() == vendor_three.BUNDLE_SHA256
    assert "MIT License" in (out / viewer.THREE_LICENSE).read_text()
    assert sorted(p.name for p in out.glob("*.js")) == [viewer.THREE_FILE]       # one copy, not one per rig
    assert page.read_text().count(f'<script src="{viewer.THREE_FILE}">') == 1
    # Beyond the inline budget the page names the rig's file instead of holding its bytes.
    result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(out), "--html", str(tmp_path / "p.html")])
    assert result.exit_code == 0
    views, blobs = viewer.rig_views(viewer_assets(out), out, assets, tmp_path, budget=0)
    assert not blobs and all(v["inline"] is None for v in views)
    assert sorted(v["href"] for v in views) == [Path(os.path.relpath(out / n, tmp_path)).as_posix()
                                                 for n in ("hero.rigged.glb", "zup.rigged.glb")]


def test_markers_beside_an_asset_are_shown_only_from_inside_the_input_folder(batch, tmp_path):
    assets, out, page = batch
    given = tmp_path / "in"
    given.mkdir()
    (given / "hero.markers.json").write_text('{"chin": [0, 1.5, 0.1], "groin": [0, "x", 1], "left_knee": [1, 2]}')
    (tmp_path / "secret.json").write_text('{"chin": [7, 7, 7]}')
    (given / "zup.markers.json").symlink_to(tmp_path / "secret.json")
    views, _ = viewer.rig_views(viewer_assets(out), out, given, tmp_path)
    shown = {v["name"]: v["given"] for v in views}
    assert shown == {"hero.obj": {"chin": [0.0, 1.5, 0.1]}, "zup.obj": {}}


def viewer_assets(out: Path):
    from autorig.batch.result import AssetResult
    report = json.loads((out / "report.json").read_text())["assets"]
    fields = AssetResult.__dataclass_fields__
    return [AssetResult(**{k: v for k, v in a.items() if k in fields}) for a in report]


def canvas_pixels(browser: Chromium, path: Path) -> np.ndarray:
    """The 3D view's pixels [H, W, 3] as the screen shows them."""
    left, top, width, height = browser.evaluate(
        "(b => [b.left, b.top, b.width, b.height])(document.getElementById('view-canvas').getBoundingClientRect())")
    browser.screenshot(path)
    with Image.open(path) as picture:
        pixels = np.asarray(picture.convert("RGB"), dtype=np.int32)
    return pixels[round(top):round(top + height), round(left):round(left + width)]


def mesh_mask(pixels: np.ndarray) -> np.ndarray:
    """Pixels of the mesh's colour, lit anywhere from dark to bright: proportional to MESH within a few levels."""
    scale = pixels.sum(axis=2, keepdims=True) / MESH.sum()
    return (np.abs(pixels - scale * MESH).max(axis=2) < 12) & (pixels.sum(axis=2) > 150)


def bone_mask(pixels: np.ndarray) -> np.ndarray:
    return np.abs(pixels - BONE).max(axis=2) < 40


def open_view(browser: Chromium, name: str) -> None:
    browser.click_on(f'article[data-name="{name}"] button.view3d')
    state = browser.wait_until("(s => s !== 'loading' && s)(document.getElementById('viewer').dataset.state)")
    assert state == "ready", browser.evaluate("document.getElementById('view-status').textContent")


@needs_chromium
def test_the_view_draws_each_rig_moves_it_and_colours_weights(batch, tmp_path):
    assets, out, page = batch
    with Chromium(width=1300, height=950) as browser:
        browser.open(page)
        for name in ("hero.obj", "zup.obj"):
            open_view(browser, name)
            pixels = canvas_pixels(browser, tmp_path / f"{name}.png")
            mesh, bones = mesh_mask(pixels), bone_mask(pixels)
            assert mesh.mean() > 0.03 and bones.sum() > 200, (name, mesh.mean(), bones.sum())
            # Stood upright whatever its axes: the body is taller than wide on screen.
            rows, columns = np.nonzero(mesh)
            assert np.ptp(rows) > 1.5 * np.ptp(columns) * 0.5 and np.ptp(rows) > 0.5 * pixels.shape[0]
            browser.click_on("#view-close")

        # The weights of a joint as colours: the left knee's warm colours appear on the left leg only.
        open_view(browser, "hero.obj")
        browser.evaluate("(m => { m.value = 'left_knee'; m.dispatchEvent(new Event('change')); })"
                         "(document.getElementById('view-joint'))")
        pixels = canvas_pixels(browser, tmp_path / "weights.png")
        warm = (pixels[..., 0] > 180) & (pixels[..., 2] < 90) & ~bone_mask(pixels)
        assert warm.sum() > 100
        columns = np.nonzero(warm)[1]
        body = np.nonzero(mesh_mask(pixels) | warm)[1]
        # The character faces the camera: its left is the picture's right.
        assert np.median(columns) > np.median(body)

        # The motion plays: two pictures apart in time differ, and stopping it brings back the rest pose.
        browser.evaluate("(m => { m.value = ''; m.dispatchEvent(new Event('change')); })"
                         "(document.getElementById('view-joint'))")
        rest = canvas_pixels(browser, tmp_path / "rest.png")
        browser.click_on("#view-move")
        browser.evaluate("new Promise(done => setTimeout(done, 350))")
        first = canvas_pixels(browser, tmp_path / "moving1.png")
        browser.evaluate("new Promise(done => setTimeout(done, 500))")
        second = canvas_pixels(browser, tmp_path / "moving2.png")
        assert (np.abs(first - second).max(axis=2) > 30).sum() > 100
        browser.click_on("#view-move")
        stopped = canvas_pixels(browser, tmp_path / "stopped.png")
        assert (np.abs(stopped - rest).max(axis=2) > 30).sum() < 20
        assert browser.console_messages() == []


@needs_chromium
def test_a_reviewer_places_markers_and_gets_the_file_in_input_coordinates(batch, tmp_path):
    assets, out, page = batch
    rig = read_glb(out / "zup.rigged.glb")
    joint = dict(zip(rig.names, rig.joints))
    vertices, faces = load_mesh(assets / "zup.obj")
    height = float(np.ptp(vertices[:, 2]))
    downloads = tmp_path / "downloads"
    downloads.mkdir()
    with Chromium(width=1300, height=950) as browser:
        browser.download_into(downloads)
        browser.open(page)
        open_view(browser, "zup.obj")
        frame = np.array(frame_rotation("z", "-y"))
        point = [0.3, -1.2, 2.5]
        assert np.allclose(browser.evaluate(f"autorigViewer.toInput({point})"), frame.T @ point)
        # The menu offers the biped's markers first, and picks the first to place.
        menu = browser.evaluate("Array.from(document.querySelectorAll('#view-marker optgroup')[0].children, "
                                "o => o.value)")
        assert menu == marker_names("biped")
        assert browser.evaluate("document.getElementById('view-marker').value") == "chin"

        # The chin: where the picture shows the head's lower part, found from the pixels alone.
        pixels = canvas_pixels(browser, tmp_path / "before.png")
        rows, columns = np.nonzero(mesh_mask(pixels))
        top, middle = rows.min(), int(np.median(columns))
        chin_row = top + int(0.09 * np.ptp(rows))
        box = browser.evaluate("(b => [b.left, b.top])(document.getElementById('view-canvas').getBoundingClientRect())")
        browser.click(box[0] + middle, box[1] + chin_row)
        # The knees and the groin: clicked where the rig draws those joints.
        for name, at in (("left_knee", "left_knee"), ("right_knee", "right_knee"), ("groin", "hips")):
            browser.evaluate(f"(m => {{ m.value = '{name}'; m.dispatchEvent(new Event('change')); }})"
                             "(document.getElementById('view-marker'))")
            x, y = browser.evaluate(f"autorigViewer.screenOf({joint[at].tolist()})")
            browser.click(x, y)
        listed = browser.evaluate("Array.from(document.querySelectorAll('#view-markers li'), li => li.textContent)")
        assert [item.split()[0] for item in listed] == ["chin", "left_knee", "right_knee", "groin"], listed
        # The markers are drawn (magenta) over the mesh; one placed by mistake is removed from the list.
        pixels = canvas_pixels(browser, tmp_path / "placed.png")
        assert (np.abs(pixels - [255, 0, 255]).max(axis=2) < 40).sum() > 4 * 20
        browser.evaluate("(m => { m.value = 'left_wrist'; m.dispatchEvent(new Event('change')); })"
                         "(document.getElementById('view-marker'))")
        browser.click(*browser.evaluate(f"autorigViewer.screenOf({joint['left_wrist'].tolist()})"))
        assert browser.evaluate("document.querySelectorAll('#view-markers li').length") == 5
        browser.click_on("#view-markers li:last-child button")
        assert browser.evaluate("document.querySelectorAll('#view-markers li').length") == 4
        browser.click_on("#view-download")
        target = downloads / "zup.markers.json"
        for _ in range(100):
            if target.is_file() and target.read_text().endswith("\n"):
                break
            browser.evaluate("new Promise(done => setTimeout(done, 50))")
        assert browser.console_messages() == []
    markers = json.loads(target.read_text())
    assert list(markers) == ["chin", "left_knee", "right_knee", "groin"]
    points = {name: np.array(p) for name, p in markers.items()}
    import igl
    distance = {name: float(np.sqrt(igl.point_mesh_squared_distance(p[None], vertices, faces)[0][0]))
                for name, p in points.items()}
    # The surface markers lie on the input's surface, in its own axes and centimetres.
    assert distance["chin"] < 0.002 * height and distance["groin"] < 0.002 * height
    assert points["chin"][2] > OFFSET[2] + 0.85 * height        # the head's height, along the input's up (z)
    # The groin was clicked over the hips: it lies in front of them (the input's front is -y), not beside.
    ahead = points["groin"] - joint["hips"]
    assert ahead[1] < -0.02 * height and abs(ahead[0]) < 0.01 * height and abs(ahead[2]) < 0.01 * height
    # The knees are joints: inside the leg, within 2 % of the height of the rig's own knees.
    for side in ("left_knee", "right_knee"):
        assert np.linalg.norm(points[side] - joint[side]) < 0.02 * height, side
    # The file is what autorig --markers reads: names the biped accepts, inside the mesh, sides agreeing.
    read = read_markers(target, "biped")
    check_markers(read, vertices, faces, left=frame[0], height=height, source=target.name)

    # Saved beside the asset, the same batch again rigs that asset with them and leaves the other as it was.
    again_assets, again_out = tmp_path / "assets", tmp_path / "rigged"
    shutil.copytree(assets, again_assets)
    shutil.copytree(out, again_out)
    shutil.copyfile(target, again_assets / "zup.markers.json")
    result = CliRunner().invoke(cli, ["batch", str(again_assets), "-o", str(again_out), "--html",
                                      str(again_out / "review.html"), "--report", str(again_out / "again.json")])
    assert result.exit_code == 0, result.output
    report = {a["input"]: a for a in json.loads((again_out / "again.json").read_text())["assets"]}
    assert report["zup.obj"]["status"] == "ok" and report["zup.obj"]["markers"] == "zup.markers.json"
    assert report["hero.obj"]["status"] == "skipped" and report["hero.obj"].get("markers") is None
    marked = read_glb(again_out / "zup.rigged.glb")
    for side in ("left_knee", "right_knee"):
        assert np.linalg.norm(marked.joints[marked.names.index(side)] - points[side]) < 0.01 * height, side
    # The new page says so on the card and shows those markers in the view.
    page_text = (again_out / "review.html").read_text()
    assert "markers zup.markers.json" in page_text
    shown = {v["name"]: v["given"] for v in views_of(again_out / "review.html") if v}
    assert shown["zup.obj"] == markers and shown["hero.obj"] == {}


@needs_chromium
def test_rigs_left_out_of_a_large_batch_page_are_read_from_their_files(batch, tmp_path, monkeypatch):
    """Past the inline budget, a page opened from disk asks for the output folder (Chromium does not let it read
    files beside it) and then reads the rig from there; served over http, it fetches the rig beside it."""
    import functools
    import http.server
    import threading
    assets, out, page = batch
    monkeypatch.setattr(viewer, "INLINE_BUDGET", 0)
    result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(out), "--html", str(out / "large.html")])
    assert result.exit_code == 0 and 'type="application/octet-stream"' not in (out / "large.html").read_text()

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(out)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        with Chromium() as browser:
            browser.open(out / "large.html")
            browser.click_on('article[data-name="zup.obj"] button.view3d')
            state = browser.wait_until("(s => s !== 'loading' && s)(document.getElementById('viewer').dataset.state)")
            assert state == "error" and "choose the output folder" in browser.evaluate(
                "document.getElementById('view-status').textContent")
            assert not browser.evaluate("document.getElementById('view-folder-box').hidden")
            # The reviewer picks the folder above the output folder: the rig is found inside it.
            node = browser.command("DOM.querySelector", {"nodeId": browser.command("DOM.getDocument")["root"]["nodeId"],
                                                         "selector": "#view-folder"})["nodeId"]
            browser.command("DOM.setFileInputFiles", {"nodeId": node, "files": [str(out.parent)]})
            browser.wait_until("document.getElementById('viewer').dataset.state === 'ready'")
            assert bone_mask(canvas_pixels(browser, tmp_path / "folder.png")).sum() > 200

            browser.open_url(f"http://127.0.0.1:{server.server_address[1]}/large.html")
            open_view(browser, "hero.obj")
            assert bone_mask(canvas_pixels(browser, tmp_path / "http.png")).sum() > 200
            assert browser.console_messages() == []
    finally:
        server.shutdown()
        server.server_close()


@pytest.fixture(scope="module")
def knee_motion(tmp_path_factory):
    """A BVH of the mannequin's own skeleton (CMU names) holding the left knee bent 60 degrees, the root 0.1 m
    down and going forward 3 cm a frame: 12 frames at 24 fps."""
    from rig_samples import mannequin_bvh
    path = tmp_path_factory.mktemp("motion") / "kneel.bvh"
    path.write_text(mannequin_bvh([{"left_knee": (60, 0, 0)}] * 12, [(0, -0.1, 0.03 * i) for i in range(12)]))
    return path


def test_a_motion_is_retargeted_onto_each_rig_for_the_page(batch, knee_motion, tmp_path):
    from scipy.spatial.transform import Rotation

    from autorig.exchange.animated_gltf import quaternions
    from autorig.exchange.bvh import read_bvh
    from autorig.show.pose import retarget
    assets, out, page = batch
    result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(out), "--html", str(out / "walk.html"),
                                      "--motion", str(knee_motion)])
    assert result.exit_code == 0, result.output
    views = {v["name"]: v for v in views_of(out / "walk.html") if v}
    for name in ("hero.obj", "zup.obj"):
        track = views[name]["motion"]
        assert track["name"] == "kneel.bvh" and track["frames"] == 12 and track["fps"] == pytest.approx(24)
        assert "left_knee" in track["joints"] and track["root"] == "hips"
        rotations = np.frombuffer(base64.b64decode(track["rotations"]), "<f4").reshape(12, len(track["joints"]), 4)
        # What autorig pose would write for that rig (float32), the left knee turning most (the root aside).
        rig = read_glb(out / name.replace(".obj", ".rigged.glb"))
        animation = retarget(rig, read_bvh(knee_motion))
        expected = quaternions(animation.local)[:, animation.animated]
        assert np.allclose(rotations, expected, atol=1e-6)
        turns = Rotation.from_quat(rotations[5].astype(np.float64)).magnitude()
        turns[track["joints"].index("hips")] = 0
        assert track["joints"][int(np.argmax(turns))] == "left_knee" and np.degrees(turns.max()) > 40
        # In place: the root goes down as the retargeted motion has it, but not forward.
        up = frame_rotation(*(("y", "z") if name == "hero.obj" else ("z", "-y")))[1]
        moved = np.frombuffer(base64.b64decode(track["translations"]), "<f4").reshape(12, 3)[5] - rig.joints[0]
        down = (animation.positions[5, 0] - rig.joints[0]) @ up
        height = float(np.ptp(rig.vertices @ up))
        assert down < -0.03 * height and moved @ up == pytest.approx(down, abs=1e-5 * height)
        assert np.linalg.norm(animation.positions[5, 0] - rig.joints[0] - down * up) > 0.04 * height
        assert np.linalg.norm(moved - (moved @ up) * up) < 1e-5 * height
    # The BVH is read before any rigging: a bad one, or one without a page to play it, stops the batch (exit 2).
    bad = tmp_path / "bad.bvh"
    bad.write_text("not a motion\n")
    for args, message in ((["--html", str(out / "x.html"), "--motion", str(bad)], "no MOTION section"),
                          (["--motion", str(knee_motion)], "--html")):
        result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(tmp_path / "none"), *args])
        assert result.exit_code == 2 and message in result.output and not (tmp_path / "none").exists()
    assert read_bvh(knee_motion).frame_time == pytest.approx(1 / 24)


@needs_chromium
def test_the_view_plays_the_motion(batch, knee_motion, tmp_path):
    assets, out, page = batch
    walk = out / "walk.html"
    if not walk.is_file():
        result = CliRunner().invoke(cli, ["batch", str(assets), "-o", str(out), "--html", str(walk),
                                          "--motion", str(knee_motion)])
        assert result.exit_code == 0, result.output
    with Chromium(width=1300, height=950) as browser:
        browser.open(walk)
        open_view(browser, "hero.obj")
        assert browser.evaluate("Array.from(document.getElementById('view-motion').options, o => o.text)") == [
            "every bone in turn", "kneel.bvh (in place)"]
        assert browser.evaluate("document.getElementById('view-motion').value") == "bvh"
        rest = canvas_pixels(browser, tmp_path / "rest.png")
        browser.click_on("#view-move")
        browser.evaluate("new Promise(done => setTimeout(done, 300))")
        bent = canvas_pixels(browser, tmp_path / "bent.png")
        changed = np.abs(bent - rest).max(axis=2) > 30
        assert changed.sum() > 200
        # The left shin swings back (the picture's right, low down); the bones point where the motion's do, so
        # the A-pose rig's arms also rise to the BVH's T.
        # Seen from the front, the bent leg's foot ends well above the other's.
        rows, columns = np.nonzero(mesh_mask(rest))
        middle, height = int(np.median(columns)), np.ptp(rows)
        feet = mesh_mask(bent)
        left_foot, right_foot = (np.nonzero(half.any(axis=1))[0].max() for half in (feet[:, middle:], feet[:, :middle]))
        assert right_foot - left_foot > 0.05 * height, (left_foot, right_foot, height)
        browser.click_on("#view-move")
        assert (np.abs(canvas_pixels(browser, tmp_path / "again.png") - rest).max(axis=2) > 30).sum() < 20
        assert browser.console_messages() == []
