"""BVH motion files (autorig.exchange.bvh): hierarchy, channel orders, frames, forward kinematics, errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from autorig.errors import InputError
from autorig.exchange.bvh import parse_bvh, read_bvh

WALK = Path(__file__).resolve().parents[2] / "shared" / "data" / "motion" / "delfem2_walk.bvh"

# A root and a two-joint arm; the elbow lists its channels in an unusual order and the name has a namespace.
TINY = """HIERARCHY
ROOT Hips
{
  OFFSET 0 1 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT mixamorig:LeftArm
  {
    OFFSET 1 0 0
    CHANNELS 3 Xrotation Zrotation Yrotation
    JOINT LeftForeArm
    {
      OFFSET 2 0 0
      CHANNELS 3 Yrotation Xrotation Zrotation
      End Site
      {
        OFFSET 1.5 0 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.5
0 1 0  0 0 0  0 0 0  0 0 0
5 1 0  90 0 0  0 0 0  0 0 0
5 2 -1  0 0 0  0 90 0  0 90 0
"""


def rz(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def ry(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def test_tiny_hierarchy_and_frames():
    motion = parse_bvh(TINY)
    assert motion.names == ["Hips", "mixamorig:LeftArm", "LeftForeArm"]
    assert motion.parents.tolist() == [-1, 0, 1]
    assert motion.channels[2] == ["Yrotation", "Xrotation", "Zrotation"]
    assert np.allclose(motion.offsets, [[0, 1, 0], [1, 0, 0], [2, 0, 0]])
    assert list(motion.end_sites) == [2] and np.allclose(motion.end_sites[2], [1.5, 0, 0])
    assert motion.frames.shape == (3, 12)
    assert motion.frame_time == 0.5
    assert np.allclose(motion.times, [0, 0.5, 1.0])
    assert np.allclose(motion.rest_positions(), [[0, 1, 0], [1, 1, 0], [3, 1, 0]])


def test_forward_kinematics_follows_channel_order():
    rotations, positions = parse_bvh(TINY).world_transforms()
    # Frame 0: the rest pose at the root's position channels.
    assert np.allclose(positions[0], [[0, 1, 0], [1, 1, 0], [3, 1, 0]])
    # Frame 1: the root turned 90 degrees about z swings the arm from +x to +y.
    assert np.allclose(positions[1], [[5, 1, 0], [5, 2, 0], [5, 4, 0]])
    # Frame 2: the arm's "X Z Y" channels (0, 90, 0) turn it about z; the elbow's "Y X Z" (0, 90, 0) would
    # turn about x, which leaves a bone along the (rotated) x axis where it is: both composed in listed order.
    assert np.allclose(rotations[2, 1], rz(90))
    assert np.allclose(positions[2], [[5, 2, -1], [6, 2, -1], [6, 4, -1]])
    assert np.allclose(rotations[2, 2] @ [1.0, 0, 0], [0, 1, 0])


def test_euler_composition_is_intrinsic_in_listed_order():
    text = TINY.replace("5 2 -1  0 0 0  0 90 0  0 90 0", "0 1 0  0 0 0  30 0 45  0 0 0")
    rotations, _ = parse_bvh(text).world_transforms()
    x30 = np.array([[1, 0, 0], [0, np.cos(np.radians(30)), -np.sin(np.radians(30))],
                    [0, np.sin(np.radians(30)), np.cos(np.radians(30))]])
    assert np.allclose(rotations[2, 1], x30 @ rz(0) @ ry(45))  # "Xrotation Zrotation Yrotation" = Rx Rz Ry


@pytest.mark.parametrize("text, message", [
    (TINY.replace("CHANNELS 3 Xrotation", "CHANNELS 3 Wrotation"), "line 9: unknown channel 'Wrotation'"),
    (TINY.replace("Frames: 3", "Frames: 4"), "4 frames of 12 channels need 48 values"),
    (TINY.replace("5 1 0  90", "5 1 0  ninety"), "line 25: a frame holds something that is not a number"),
    (TINY.replace("OFFSET 2 0 0", "OFFSET 2 0"), "line 13: expected a number but found 'CHANNELS'"),
    (TINY.split("MOTION")[0], "no MOTION section"),
    (TINY.replace("Frame Time: 0.5", "Frame Time: 0"), "bad frame count 3 or frame time 0"),
])
def test_errors_name_the_line(text, message):
    with pytest.raises(InputError, match=message):
        parse_bvh(text, name="tiny.bvh")


def test_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        read_bvh(tmp_path / "absent.bvh")


@pytest.mark.skipif(not WALK.exists(), reason="shared data (../shared/data) is not present")
def test_cmu_walk():
    motion = read_bvh(WALK)
    assert len(motion.names) == 31
    assert motion.frames.shape == (344, 96)
    assert motion.frame_time == pytest.approx(0.0083333, abs=1e-7)
    assert motion.names[:6] == ["Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"]
    _, positions = motion.world_transforms()
    hips, head, foot = (positions[:, motion.names.index(n)] for n in ("Hips", "Head", "LeftFoot"))
    assert np.all(head[:, 1] > hips[:, 1]) and np.all(foot[:, 1] < hips[:, 1])  # upright all along
    assert hips[-1, 2] - hips[1, 2] > 40  # walks some 60 units forward along +z
