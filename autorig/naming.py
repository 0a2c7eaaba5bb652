"""Joint naming schemes for the output: the template's own names, or Mixamo's.

    rig = rename_joints(rig, "mixamo")     # biped joints as mixamorig:Hips, mixamorig:LeftUpLeg, ...

Mixamo's names are what animation libraries and Unity's Humanoid auto-mapping recognise. The biped's upper arm
joint (``left_shoulder``) is Mixamo's ``LeftArm`` (Mixamo's ``LeftShoulder`` is the collarbone, which the
biped has not); ``chest`` is ``Spine1``; the tips are Mixamo's end joints (``HeadTop_End``, ``LeftToe_End``,
``LeftHandMiddle4`` at the finger tips).
"""
from __future__ import annotations

from dataclasses import replace

from .errors import TemplateError
from .result import Rig

__all__ = ["NAME_SCHEMES", "MIXAMO", "rename_joints", "check_names", "template_names"]

NAME_SCHEMES = ("template", "mixamo")


def _mixamo() -> dict[str, str]:
    names = {"hips": "Hips", "spine": "Spine", "chest": "Spine1", "neck": "Neck", "head": "Head",
             "head_end": "HeadTop_End"}
    for side in ("left", "right"):
        S = side.capitalize()
        names.update({f"{side}_shoulder": f"{S}Arm", f"{side}_elbow": f"{S}ForeArm", f"{side}_wrist": f"{S}Hand",
                      f"{side}_hand_end": f"{S}HandMiddle4", f"{side}_hip": f"{S}UpLeg", f"{side}_knee": f"{S}Leg",
                      f"{side}_ankle": f"{S}Foot", f"{side}_toe": f"{S}ToeBase", f"{side}_toe_end": f"{S}Toe_End"})
    return {joint: "mixamorig:" + name for joint, name in names.items()}


MIXAMO: dict[str, str] = _mixamo()
_FROM_MIXAMO = {name: joint for joint, name in MIXAMO.items()}

# ---------------------------------------------------------------- fingers (autorig.hands), a block of its own
# A rig with fingers (``autorig.hands``) names them too: mixamorig:LeftHandIndex1..4. Its fingertip
# LeftHandMiddle4 is then the middle finger's tip, and hand_end takes LeftHand_End instead.
from .hands.names import FINGER_NAMES, HAND_END_BESIDE_FINGERS  # noqa: E402

_FINGERED_MIXAMO = {**MIXAMO, **HAND_END_BESIDE_FINGERS["mixamo"], **FINGER_NAMES["mixamo"]}
_FROM_FINGERED_MIXAMO = {name: joint for joint, name in _FINGERED_MIXAMO.items()}


def _has_fingers(names) -> bool:
    """Whether joint names (the template's or Mixamo's) include finger joints."""
    return any(n in FINGER_NAMES["mixamo"] or n in _FROM_FINGERED_MIXAMO and n not in _FROM_MIXAMO for n in names)
# ---------------------------------------------------------------- end of the fingers' block


def rename_joints(rig: Rig, scheme: str) -> Rig:
    """``rig`` with its joints named by ``scheme`` (one of ``NAME_SCHEMES``; "template" leaves it as it is).

    Raises ``TemplateError`` when the rig lacks any of the biped template's joints, which are all Mixamo
    names; joints beyond them (a learned template's helper joints) keep their own names.
    """
    check_names(rig.names, scheme)
    if scheme == "template":
        return rig
    table = _FINGERED_MIXAMO if _has_fingers(rig.names) else MIXAMO
    return replace(rig, names=[table.get(name, name) for name in rig.names])


def check_names(joint_names: list[str], scheme: str) -> None:
    """Raise ``TemplateError`` unless joints called ``joint_names`` can be named by ``scheme``."""
    if scheme not in NAME_SCHEMES:
        raise TemplateError(f"unknown joint names {scheme!r}: choose one of {', '.join(NAME_SCHEMES)}")
    missing = [name for name in MIXAMO if name not in joint_names] if scheme == "mixamo" else []
    if missing:
        raise TemplateError(f"--names mixamo: Mixamo names the biped template's joints, and these joints are not "
                            f"the biped's (no {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''})")


def template_names(names: list[str]) -> list[str]:
    """The template's names for joint names that may be Mixamo's (others are returned as they are)."""
    table = _FROM_FINGERED_MIXAMO if _has_fingers(names) else _FROM_MIXAMO
    return [table.get(name, name) for name in names]
