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
