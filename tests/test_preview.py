"""Pictures of a rig (autorig.show.preview, `autorig preview`, `autorig --preview`)."""
from __future__ import annotations

import importlib.util
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner
from rig_samples import rigged_mannequin

from autorig import pipeline
from autorig.cli import cli
from autorig.exchange.gltf import write_glb
from autorig.input.mesh import frame_rotation

pytest.importorskip("matplotlib", reason="the preview extra (matplotlib) is not installed")
from PIL import Image  # noqa: E402  (Pillow comes with matplotlib)

from autorig.show.preview import render_preview  # noqa: E402

TETRA_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


@pytest.fixture(scope="module")
def rig():
    return rigged_mannequin()[1]


def pixels(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


def crop(image: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    left, top, right, bottom = box
    return image[top:bottom, left:right]


def test_two_views_of_a_coloured_mesh_with_its_skeleton(rig, tmp_path):
    path = tmp_path / "hero.png"
    boxes = render_preview(rig, path)
    image = pixels(path)
    height, width = image.shape[:2]
    assert path.stat().st_size > 20_000
    assert 900 <= width <= 2600 and 600 <= height <= 1000
    assert list(boxes) == ["front", "side"]
    front, side = boxes["front"], boxes["side"]
    assert front[2] < side[0]  # side by side, front first
    for left, top, right, bottom in boxes.values():
        assert 0 <= left < right <= width and 0 <= top < bottom <= height
        assert bottom - top > 0.7 * height
    for box in boxes.values():
        view = crop(image, box).reshape(-1, 3).astype(int)
        # Shaded faces in many colours, the skeleton's black bones and red joints over them.
        assert len(np.unique(view // 16, axis=0)) > 40
        assert np.sum(np.all(view < 40, axis=1)) > 200
        assert np.sum((view[:, 0] > 200) & (view[:, 1] < 60) & (view[:, 2] < 60)) > 50
    # The front view of a T-pose is wider than the side view; the legend lies to the right of both.
    assert front[2] - front[0] > side[2] - side[0]
    legend = image[:, side[2]:].reshape(-1, 3).astype(int)
    assert len(np.unique(legend // 16, axis=0)) > 15


def test_the_picture_follows_the_rigs_own_frame(rig, tmp_path):
    """The same character stored Z-up and facing -y gives the same picture."""
    rotation = frame_rotation("z", "-y").T  # canonical -> input coordinates
    turned = replace(rig, vertices=rig.vertices @ rotation.T, joints=rig.joints @ rotation.T,
                     info={**rig.info, "up": "z", "front": "-y"})
    render_preview(rig, tmp_path / "a.png", title="same")
    render_preview(turned, tmp_path / "b.png", title="same")
    render_preview(turned, tmp_path / "c.png", title="same", up="y", front="z")
    assert np.array_equal(pixels(tmp_path / "a.png"), pixels(tmp_path / "b.png"))
    assert not np.array_equal(pixels(tmp_path / "a.png"), pixels(tmp_path / "c.png"))


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="autorig")


def test_preview_command(rig, tmp_path):
    write_glb(rig, tmp_path / "hero.glb")
    result = run("preview", tmp_path / "hero.glb")
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"{tmp_path / 'hero.glb'}: 24 joints (19 + 5 tips), {len(rig.vertices)} " \
                                    f"vertices in the file -> " \
                                    f"{tmp_path / 'hero.png'}"
    assert pixels(tmp_path / "hero.png").shape[1] > 900
    result = run("preview", tmp_path / "hero.glb", "-o", tmp_path / "other.png", "--title", "Hero", "-q")
    assert result.exit_code == 0 and result.stdout == ""
    assert (tmp_path / "other.png").exists()


def test_the_command_draws_a_file_in_the_axes_autorig_recorded(rig, tmp_path):
    """A Z-up character's rig file is drawn upright without --up/--front: the file says how it stands."""
    rotation = frame_rotation("z", "-y").T  # canonical -> input coordinates
    turned = replace(rig, vertices=rig.vertices @ rotation.T, joints=rig.joints @ rotation.T,
                     info={**rig.info, "up": "z", "front": "-y"})
    write_glb(rig, tmp_path / "upright.glb")
    write_glb(turned, tmp_path / "lying.glb")
    for name, extra in (("upright", []), ("lying", []), ("told", ["--up", "y", "--front", "z"])):
        source = tmp_path / ("upright.glb" if name == "upright" else "lying.glb")
        result = run("preview", source, "-o", tmp_path / f"{name}.png", "--title", "same", "-q", *extra)
        assert result.exit_code == 0, result.output
    assert np.array_equal(pixels(tmp_path / "upright.png"), pixels(tmp_path / "lying.png"))
    assert not np.array_equal(pixels(tmp_path / "upright.png"), pixels(tmp_path / "told.png"))
    # Axes that contradict the file's are one error line.
    result = run("preview", tmp_path / "lying.glb", "--front", "z", "-o", tmp_path / "bad.png")
    assert result.exit_code == 2 and "parallel" in result.stderr


def test_preview_command_errors(tmp_path):
    result = run("preview", tmp_path / "absent.glb")
    assert result.exit_code == 2 and result.stderr.startswith("autorig: error: cannot read")
    (tmp_path / "hero.glb").write_bytes(b"glTF")
    result = run("preview", tmp_path / "hero.glb", "-o", tmp_path / "hero.glb")
    assert result.exit_code == 4 and "would overwrite the input" in result.stderr


@pytest.mark.parametrize("fmt, picture", [("glb", "hero.rigged.png"), ("pinocchio", "hero.rigged.png"),
                                          ("json", "hero.rigged.png")])
def test_rig_preview_flag(rig, tmp_path, monkeypatch, fmt, picture):
    monkeypatch.setattr(pipeline, "rig", lambda mesh, template="biped", options=None: rig)
    (tmp_path / "hero.obj").write_text(TETRA_OBJ)
    result = run(tmp_path / "hero.obj", "--preview", "--format", fmt)
    assert result.exit_code == 0, result.output
    assert result.stdout.rstrip().endswith(f"(preview {tmp_path / picture})")
    assert pixels(tmp_path / picture).shape[0] > 600


def test_missing_matplotlib_fails_before_rigging(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(pipeline, "rig", lambda *args, **kwargs: calls.append(args))
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *args: None if name == "matplotlib" else real_find_spec(name, *args))
    (tmp_path / "hero.obj").write_text(TETRA_OBJ)
    result = run(tmp_path / "hero.obj", "--preview")
    assert result.exit_code == 9 and calls == []     # its own code: a missing optional package
    assert result.stderr.strip() == "autorig: error: --preview needs matplotlib: pip install 'autorig[preview]'"


def test_a_star_lying_flat_is_seen_from_above(tmp_path):
    """Six arms round a flat ring: from the front or side they would overlap; from above each shows apart."""
    import autorig
    from autorig.extract.shapes import CreatureSpec, LimbSpec, _layout_directions, creature

    arms = tuple(LimbSpec(tuple(d), 1.8, 3.0, 1.0, 0.0, (0.0, 1.0, 0.0), 0.5)
                 for d in _layout_directions(6, "flat", 0.2))
    shape = creature(CreatureSpec("ellipsoid", (1.0, 0.6, 1.0), (0.0, 0.0, 0.0), (), arms, True))
    star = autorig.rig((shape.vertices, shape.faces), "auto", autorig.RigOptions(up="y", front="z", voxels=48))
    path = tmp_path / "star.png"
    boxes = render_preview(star, path)
    assert list(boxes)[0] == "top" and len(boxes) == 2
    top = boxes["top"]
    other = next(box for name, box in boxes.items() if name != "top")
    assert top[3] - top[1] >= other[3] - other[1]              # the top view is the tall one
    image = crop(pixels(path), top)
    assert (image.min(axis=2) < 200).mean() > 0.15                 # a mesh drawn there, not an empty box


def fingered_mixamo(rig):
    """``rig`` with five fingers of three joints and a tip on each hand, fanned out past its wrist, every joint
    named as Mixamo names it: the dense skeleton whose labels crowd a preview (64 joints, 49 of them not tips)."""
    from autorig.hands.names import FINGERS, finger_joint_names
    from autorig.naming import rename_joints

    names, parents, joints = list(rig.names), list(rig.parents), [*rig.joints]
    height = float(np.ptp(rig.vertices[:, 1]))
    for side in ("left", "right"):
        wrist = names.index(f"{side}_wrist")
        out = rig.joints[names.index(f"{side}_hand_end")] - rig.joints[wrist]
        out /= np.linalg.norm(out)
        for f, finger in enumerate(FINGERS):
            parent = wrist
            for k in range(4):
                names.append(finger_joint_names()[(0 if side == "left" else 20) + 4 * f + k])
                joints.append(rig.joints[wrist] + height * (0.03 + 0.02 * k) * out
                              + height * 0.012 * (f - 2) * np.array([0.0, 0.0, 1.0]))
                parents.append(parent)
                parent = len(names) - 1
    weights = np.hstack([rig.weights, np.zeros((len(rig.weights), len(names) - len(rig.names)))])
    dense = replace(rig, names=names, parents=np.array(parents), joints=np.array(joints), weights=weights)
    return rename_joints(dense, "mixamo")


def test_dense_labels_do_not_overlap_and_stay_inside(rig, tmp_path):
    """With fingers and Mixamo's long names, every label drawn (measured: its text's extent) lies inside the
    picture and its view, and overlaps no other label, the titles or the legend."""
    from autorig.show.preview import draw_preview

    dense = fingered_mixamo(rig)
    assert len(dense.names) == 64 and dense.names[0] == "mixamorig:Hips"
    figure, boxes = draw_preview(dense)
    renderer = figure.canvas.get_renderer()
    whole = figure.bbox
    labels = [text for ax in figure.axes for text in ax.texts if text.get_gid() == "joint label"]
    extents = [type(text).__mro__[1].get_window_extent(text, renderer) for text in labels]   # the text alone
    named = {text.get_text() for text in labels}
    not_tips = len(dense.names) - 15                 # 5 of the biped's tips, 10 finger tips (Mixamo's 4s)
    assert len(named) >= 0.8 * not_tips, len(named)  # most joints named: those left out had no room anywhere
    assert any("Index" in text.get_text() for text in labels)
    others = [figure._suptitle.get_window_extent(renderer)] + \
        [ax.title.get_window_extent(renderer) for ax in figure.axes if ax.title.get_text()] + \
        [ax.get_legend().get_window_extent(renderer) for ax in figure.axes if ax.get_legend()]
    for other in others:               # the titles and legend are not cut off either
        assert whole.x0 <= other.x0 and other.x1 <= whole.x1 and whole.y0 <= other.y0 and other.y1 <= whole.y1
    for k, box in enumerate(extents):
        assert whole.x0 <= box.x0 and box.x1 <= whole.x1 and whole.y0 <= box.y0 and box.y1 <= whole.y1
        view = labels[k].axes.get_window_extent(renderer)
        assert view.x0 <= box.x0 and box.x1 <= view.x1 and view.y0 <= box.y0 and box.y1 <= view.y1
        for other in extents[k + 1:] + others:
            assert not box.overlaps(other), (labels[k].get_text(), box, other)
    render_preview(dense, tmp_path / "dense.png")
    assert pixels(tmp_path / "dense.png").shape[1] > 1000
