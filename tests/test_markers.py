"""--markers (issue 38): the templates' marker sets, the markers file and its one-line errors, and the rig
holding the marked joints at their markers."""
import json

import numpy as np
import pytest

from autorig.errors import InputError
from autorig.markers import accepted_names, marker_names, markers_from, read_markers


def test_each_template_documents_its_marker_set():
    assert marker_names("biped") == ["chin", "left_wrist", "right_wrist", "left_elbow", "right_elbow",
                                     "left_knee", "right_knee", "groin"]
    assert marker_names("humanoid") == marker_names("biped")
    assert marker_names("quadruped") == ["front_left_paw", "front_right_paw", "back_left_paw", "back_right_paw",
                                         "head", "tail_base", "withers"]
    assert marker_names("horse") == marker_names("quadruped")
    assert {"chin", "left_wrist", "front_left_paw", "tail_base"} <= set(marker_names("centaur"))
    accepted = accepted_names("biped")
    assert accepted[:8] == marker_names("biped") and "left_ankle" in accepted and "hips" in accepted


def test_a_markers_file_is_read_in_the_inputs_own_coordinates(tmp_path):
    path = tmp_path / "hero.markers.json"
    path.write_text(json.dumps({"chin": [0, 1.5, 0.1], "left_ankle": [0.1, 0.05, 0]}))
    markers = read_markers(path, "biped")
    assert list(markers) == ["chin", "left_ankle"]
    assert np.allclose(markers["chin"], [0, 1.5, 0.1])


@pytest.mark.parametrize("text, says", [
    ("{not json", "not JSON"),
    ("[1, 2, 3]", "must be a JSON object"),
    ("{}", "no markers"),
    ('{"nose": [0, 1, 0]}', "unknown marker 'nose'; the template accepts: chin, left_wrist"),
    ('{"chin": [0, 1]}', "three finite numbers"),
    ('{"chin": [0, 1, "a"]}', "three finite numbers"),
    ('{"chin": [0, 1, 1e999]}', "three finite numbers"),
    ('{"chin": [0, 1, 0], "head": [0, 1, 0]}', "both place the joint 'head'"),
])
def test_a_bad_markers_file_is_one_line_of_bad_input(tmp_path, text, says):
    path = tmp_path / "bad.markers.json"
    path.write_text(text)
    with pytest.raises(InputError) as caught:
        read_markers(path, "biped")
    assert says in str(caught.value) and "\n" not in str(caught.value)
    assert caught.value.exit_code == 2


def test_markers_given_as_a_dict_are_checked_the_same_way():
    with pytest.raises(InputError, match="unknown marker 'withers'"):
        markers_from({"withers": [0, 1, 0]}, "biped")
    assert set(markers_from({"withers": [0, 1, 0]}, "horse")) == {"withers"}


# --- the rig honours them ---------------------------------------------------------------------------------------

from click.testing import CliRunner  # noqa: E402

import autorig  # noqa: E402
from autorig.cli import cli  # noqa: E402
from autorig.markers import marker_of  # noqa: E402

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]
CESIUM = ROOT.parent / "shared" / "data" / "rigged" / "CesiumMan"
MANNEQUIN = ROOT / "data" / "mannequin.obj"
needs_shared = pytest.mark.skipif(not CESIUM.is_dir(), reason="shared data (../shared/data) is not present")


def _artist_markers(folder):
    """The biped's marker set from an artist's rig (``joints.json``): wrists, elbows and knees at the artist's
    joints, the chin and groin where their joints' heights put them; and the height along up."""
    meta = json.loads((folder / "joints.json").read_text())
    position = {j["name"]: np.array(j["position"], float) for j in meta["joints"]}
    truth = {key: position[name] for key, name in meta["biped_map"].items() if name}
    axis = meta["up_axis"]
    up = np.eye(3)["xyz".index(axis[-1])] * (-1.0 if axis.startswith("-") else 1.0)
    height = float(meta["height_along_up"])
    markers = {}
    for name in marker_names("biped"):
        marker = marker_of(name)
        markers[name] = (truth[marker.joint] - marker.offset[1] * height * up).tolist()
    return markers, truth, height


@needs_shared
def test_marked_joints_land_at_their_markers_on_a_shared_character(tmp_path):
    markers, truth, height = _artist_markers(CESIUM)
    path = tmp_path / "cesium.markers.json"
    path.write_text(json.dumps(markers))
    result = CliRunner().invoke(cli, [str(CESIUM / "mesh.obj"), "--markers", str(path), "-o",
                                      str(tmp_path / "cesium.glb")], prog_name="autorig")
    assert result.exit_code == 0, result.output
    assert "8 markers held" in result.stdout
    from autorig.exchange.gltf import read_glb
    rig = read_glb(tmp_path / "cesium.glb")
    joints = dict(zip(rig.names, np.asarray(rig.joints, float)))
    for name in ("left_wrist", "right_wrist", "left_elbow", "right_elbow", "left_knee", "right_knee"):
        assert np.linalg.norm(joints[name] - markers[name]) < 0.01 * height, name
    # the chin and the groin hold the head's and the hips' height and side-to-side place (CesiumMan: +y up, +x front)
    for joint in ("head", "hips"):
        assert np.linalg.norm((joints[joint] - truth[joint])[[1, 2]]) < 0.01 * height, joint
    # and the library takes the same markers as a dict, with the same result
    library = autorig.rig(str(CESIUM / "mesh.obj"), "biped", autorig.RigOptions(markers=markers))
    assert library.info["markers"] == list(markers) and library.info["marker_error"] < 0.01
    assert np.allclose(library.joints[library.names.index("left_wrist")], markers["left_wrist"], atol=1e-4)


def _cli_error(args):
    result = CliRunner().invoke(cli, args, prog_name="autorig")
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("autorig: error: "), result.stderr
    assert "Traceback" not in result.output
    return result.exit_code, lines[0]


@pytest.mark.parametrize("text, says", [
    ("not json", "not JSON"),
    ('["chin"]', "must be a JSON object"),
    ('{"nose": [0, 1, 0]}', "unknown marker 'nose'"),
    ('{"chin": [0, 1, null]}', "three finite numbers"),
])
def test_the_command_line_refuses_a_bad_markers_file_before_the_work(tmp_path, text, says):
    path = tmp_path / "m.json"
    path.write_text(text)
    code, line = _cli_error([str(MANNEQUIN), "--markers", str(path), "-o", str(tmp_path / "out.glb")])
    assert code == 2 and says in line
    assert not (tmp_path / "out.glb").exists()


def test_a_marker_outside_the_mesh_or_swapped_sides_is_one_error_line(tmp_path):
    rig = autorig.rig(str(MANNEQUIN), "biped", autorig.RigOptions(up="y", front="z"))
    at = dict(zip(rig.names, rig.joints.tolist()))
    height = float(np.ptp(rig.vertices[:, 1]))
    cases = {
        "outside": ({"left_wrist": [at["left_wrist"][0], at["left_wrist"][1] + 0.2 * height, at["left_wrist"][2]]},
                    "lies outside the mesh"),
        "swapped": ({"left_wrist": at["right_wrist"], "right_wrist": at["left_wrist"]}, "are swapped"),
    }
    for label, (markers, says) in cases.items():
        path = tmp_path / f"{label}.json"
        path.write_text(json.dumps(markers))
        code, line = _cli_error([str(MANNEQUIN), "--up", "y", "--front", "z", "--markers", str(path), "-o",
                                 str(tmp_path / "out.glb")])
        assert code == 2 and says in line and f"{label}.json" in line, line
    # markers above or in front of one another are no contradiction, only left and right
    fine = {"left_wrist": at["left_wrist"], "right_knee": at["right_knee"], "left_knee": at["left_knee"]}
    held = autorig.rig(str(MANNEQUIN), "biped", autorig.RigOptions(up="y", front="z", markers=fine))
    assert held.info["markers"] == list(fine)


def test_batch_rigs_an_asset_with_the_markers_file_beside_it(tmp_path):
    from autorig.batch import rig_folder
    source = tmp_path / "in"
    source.mkdir()
    for name in ("a", "b"):
        (source / f"{name}.obj").write_bytes(MANNEQUIN.read_bytes())
    plain = autorig.rig(str(MANNEQUIN), "biped")
    at = dict(zip(plain.names, plain.joints.tolist()))
    wrist = [at["left_wrist"][0], at["left_wrist"][1] - 0.02, at["left_wrist"][2]]
    (source / "a.markers.json").write_text(json.dumps({"left_wrist": wrist}))
    result = rig_folder(source, tmp_path / "out", "biped", jobs=1)
    by_name = {a.input: a for a in result.assets}
    assert by_name["a.obj"].markers == "a.markers.json" and by_name["b.obj"].markers is None
    from autorig.exchange.gltf import read_glb
    marked = read_glb(tmp_path / "out" / "a.rigged.glb")
    assert np.allclose(marked.joints[marked.names.index("left_wrist")], wrist, atol=1e-4)
    unmarked = read_glb(tmp_path / "out" / "b.rigged.glb")
    assert np.allclose(unmarked.joints, plain.joints, atol=1e-5)
    # a changed markers file rigs that asset again and leaves the other as it is
    (source / "a.markers.json").write_text(json.dumps({"left_wrist": at["left_wrist"]}))
    again = {a.input: a.status for a in rig_folder(source, tmp_path / "out", "biped", jobs=1).assets}
    assert again == {"a.obj": "ok", "b.obj": "skipped"}


def test_a_markers_path_that_is_no_small_regular_file_is_one_line(tmp_path):
    big = tmp_path / "big.json"
    big.write_bytes(b" " * (2 << 20))
    for path, says in ((tmp_path / "none.json", "not found"), (tmp_path, "not a regular file"),
                       (big, "more than the 1 MB")):
        code, line = _cli_error([str(MANNEQUIN), "--markers", str(path), "-o", str(tmp_path / "out.glb")])
        assert code == 2 and says in line, line
