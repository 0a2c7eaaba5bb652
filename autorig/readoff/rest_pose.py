"""The rest pose a character was modelled in, read off its rig: T-pose, A-pose or arms hanging.

Characters arrive with their arms straight out (T), 30-45 degrees down (A) or hanging by their sides; the same
template rigs all three (its learned arms hang at the mean of its examples' poses, and the embedding's paths,
the refinement and the placement follow the mesh's own arms). What the rig found is reported in its ``info``
(``rest_pose``: the pose's name and the arms' angle), so that a retargeting tool or a user knows which
rest pose the bind pose is:

    angle    degrees below the horizontal of the line from the upper arm joint (``{side}_shoulder``) to the
             wrist, in the canonical frame (+y up), averaged over the two arms: 0 straight out, 90 hanging
    pose     "T" below T_MAX, "A" up to A_MAX, "arms down" beyond
"""
from __future__ import annotations

import numpy as np

T_MAX = 20.0    # degrees: arms this close to horizontal are a T-pose
A_MAX = 55.0    # degrees: an A-pose's arms are 30-45 degrees down; beyond this they hang


def arm_angle(joints: np.ndarray, names) -> float | None:
    """Degrees below the horizontal of the arms of the rig ``joints`` [J, 3] (canonical frame, +y up) whose
    joints are called ``names`` [J]; None for a template without both arms' shoulder and wrist."""
    index = {n: i for i, n in enumerate(names)}
    angles = []
    for side in ("left", "right"):
        shoulder, wrist = index.get(f"{side}_shoulder"), index.get(f"{side}_wrist")
        if shoulder is None or wrist is None:
            return None
        arm = np.asarray(joints[wrist], float) - np.asarray(joints[shoulder], float)
        across = float(np.hypot(arm[0], arm[2]))
        angles.append(float(np.degrees(np.arctan2(-arm[1], across))))
    return float(np.mean(angles))


def pose_name(angle: float) -> str:
    """"T", "A" or "arms down" for arms ``angle`` degrees below the horizontal."""
    return "T" if angle < T_MAX else "A" if angle <= A_MAX else "arms down"


def rest_pose(joints: np.ndarray, names) -> dict:
    """{"rest_pose": name, "arm_angle": degrees} of the rig ``joints`` [J, 3] (canonical frame) for a rig's
    ``info``; {} for a template without arms (a quadruped's forelegs are no rest-pose choice)."""
    angle = arm_angle(joints, names)
    if angle is None:
        return {}
    return {"rest_pose": pose_name(angle), "arm_angle": round(angle, 1)}

