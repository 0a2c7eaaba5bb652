"""The finger joints' names in each engine's scheme, for ``autorig.naming``.

    {side}_{finger}1, 2, 3, _end       (autorig's own: left_index1, ..., left_index_end)
    mixamo   mixamorig:LeftHandIndex1, 2, 3, 4          (4: Mixamo's own tip joints)
    unreal   index_01_l, index_02_l, index_03_l, index_03_end_l
    unity    LeftIndexProximal, LeftIndexIntermediate, LeftIndexDistal, LeftIndexDistal_End
             (Unity's HumanBodyBones, written as the body's joints are: LeftUpperArm, LeftHand; Unity calls
             the pinky the little finger: LeftLittleProximal)

The tips of the Unreal and Unity schemes, which have no tip bones of their own, are named after their bone
with ``_end``/``_End``. A rig with fingers ends its fingers at Mixamo's ``LeftHandMiddle4``, the name the
biped's ``hand_end`` takes without fingers; beside fingers ``hand_end`` becomes ``LeftHand_End``.
"""
from __future__ import annotations

FINGERS = ("thumb", "index", "middle", "ring", "pinky")   # the digits, in this order everywhere
SIDES = {"left": ("Left", "l"), "right": ("Right", "r")}
_UNITY_PHALANX = ("Proximal", "Intermediate", "Distal")


def finger_joint_names() -> list[str]:
    """autorig's finger joint names [40], each side's digits in FINGERS order, 1, 2, 3, _end."""
    return [f"{side}_{finger}{suffix}" for side in SIDES for finger in FINGERS
            for suffix in ("1", "2", "3", "_end")]


def _scheme(scheme: str) -> dict[str, str]:
    out = {}
    for side, (S, s) in SIDES.items():
        for finger in FINGERS:
            F = finger.capitalize()
            for k in range(4):
                joint = f"{side}_{finger}{k + 1}" if k < 3 else f"{side}_{finger}_end"
                if scheme == "mixamo":
                    out[joint] = f"mixamorig:{S}Hand{F}{k + 1}"
                elif scheme == "unreal":
                    out[joint] = f"{finger}_0{min(k, 2) + 1}_{'end_' if k == 3 else ''}{s}"
                else:
                    digit = "Little" if finger == "pinky" else F
                    out[joint] = f"{S}{digit}{_UNITY_PHALANX[min(k, 2)]}" + ("_End" if k == 3 else "")
    return out


FINGER_NAMES: dict[str, dict[str, str]] = {scheme: _scheme(scheme) for scheme in ("mixamo", "unreal", "unity")}

# hand_end's name beside fingers, where the scheme would otherwise give it a finger's name.
HAND_END_BESIDE_FINGERS: dict[str, dict[str, str]] = {
    "mixamo": {f"{side}_hand_end": f"mixamorig:{S}Hand_End" for side, (S, _) in SIDES.items()},
}


def motion_names() -> dict[str, tuple[str, ...]]:
    """{finger joint: motion joint names to look for}: Mixamo's and Unreal's finger bones, for
    ``autorig.show.pose``'s map (compared without a namespace prefix)."""
    out = {}
    for joint, name in FINGER_NAMES["mixamo"].items():
        out[joint] = (name.split(":")[-1], FINGER_NAMES["unreal"][joint])
    return out


__all__ = ["FINGERS", "FINGER_NAMES", "HAND_END_BESIDE_FINGERS", "finger_joint_names", "motion_names"]
