"""The trunk-depth table of ``benchmarks/quadruped_conventions.py`` on constructed shapes: where a vertical line
crosses a mesh, and the one depth fraction that leaves the least worst error."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from quadruped_conventions import best_fraction, column  # noqa: E402


def test_a_vertical_line_finds_the_boxs_belly_and_back():
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.apply_translation((0.0, 1.5, 0.0))                  # from y = 0.5 to 2.5
    low, high = column(np.asarray(box.vertices), np.asarray(box.faces), 0.1, -0.7)
    assert low == pytest.approx(0.5) and high == pytest.approx(2.5)
    assert column(np.asarray(box.vertices), np.asarray(box.faces), 0.1, 2.0) is None    # beside the box


def test_one_fraction_is_the_middle_of_the_spread_weighted_by_depth():
    # Two animals of the same depth at 0.2 and 0.8 of it: the best one fraction is 0.5, 0.3 depths off each.
    fraction, worst = best_fraction([(0.2, 0.4), (0.8, 0.4)])
    assert fraction == pytest.approx(0.5, abs=1e-3) and worst == pytest.approx(0.12, abs=1e-3)
    # A deeper body weighs more: the fraction moves toward its joint.
    fraction, _ = best_fraction([(0.2, 0.8), (0.8, 0.4)])
    assert fraction < 0.45


def test_an_artists_joint_outside_the_mesh_is_named():
    from quadruped_conventions import outside_joints
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    animal = {"vertices": np.asarray(box.vertices), "faces": np.asarray(box.faces), "height": 2.0,
              "joints": {"hips": np.zeros(3), "paw": np.array([0.0, 0.0, 1.6]), "shoulder": np.array([0.0, 0.0, 1.51])}}
    out = outside_joints(animal)          # the box ends at z = 1.5: the paw 0.1 outside, the shoulder 0.01
    assert list(out) == ["paw"] and out["paw"] == pytest.approx(0.05, abs=1e-6)
