"""Joint naming schemes for the output: the template's own names, Mixamo's, Unity Humanoid's or Unreal's.

    rig = rename_joints(rig, "mixamo")     # biped joints as mixamorig:Hips, mixamorig:LeftUpLeg, ...

Each scheme names the body of the biped and of the humanoid (``templates/humanoid.json``: three spine joints and
clavicles), so that a rig loads into the engine's retargeting as its own skeleton:

- mixamo: what animation libraries and Unity's auto-mapping recognise. The upper arm (``left_shoulder``) is
  Mixamo's ``LeftArm``; Mixamo's ``LeftShoulder`` is the collarbone, the humanoid's ``left_clavicle``. The
  biped's ``chest`` is ``Spine1``; the humanoid's ``spine1`` and ``spine2`` are ``Spine1`` and ``Spine2``. Tips
  are Mixamo's end joints (``HeadTop_End``, ``LeftToe_End``, ``LeftHandMiddle4`` at the finger tips).
- unity: Unity's HumanBodyBones names (``Hips``, ``Spine``, ``Chest``, ``UpperChest``, ``LeftShoulder``,
  ``LeftUpperArm``, ``LeftLowerArm``, ``LeftHand``, ``LeftUpperLeg``, ``LeftLowerLeg``, ``LeftFoot``,
  ``LeftToes``): an avatar maps every required bone by name. The biped's chest is ``Chest``.
- unreal: the UE mannequin's (``pelvis``, ``spine_01..03``, ``neck_01``, ``head``, ``clavicle_l``,
  ``upperarm_l``, ``lowerarm_l``, ``hand_l``, ``thigh_l``, ``calf_l``, ``foot_l``, ``ball_l``); the biped's
  chest is ``spine_03``, the bone the mannequin's clavicles and neck hang from.

Engines have no tip bones of their own except Mixamo; tips are named after their bone with ``_End``/``_end``.
"""
from __future__ import annotations

from dataclasses import replace

from .errors import TemplateError
from .hands.names import FINGER_NAMES, HAND_END_BESIDE_FINGERS, finger_joint_names
from .result import Rig

__all__ = ["NAME_SCHEMES", "MIXAMO", "BIPED_JOINTS", "HUMANOID_JOINTS", "scheme_names", "rename_joints",
           "check_names", "template_names"]

NAME_SCHEMES = ("template", "mixamo", "unity", "unreal")

SIDES = ("left", "right")
_LIMB = ("shoulder", "elbow", "wrist", "hand_end", "hip", "knee", "ankle", "toe", "toe_end")
BIPED_JOINTS = ("hips", "spine", "chest", "neck", "head", "head_end",
                *(f"{side}_{joint}" for side in SIDES for joint in _LIMB))
HUMANOID_JOINTS = tuple(n for n in BIPED_JOINTS if n != "chest") + (
    "spine1", "spine2", "left_clavicle", "right_clavicle")


# ------------------------------------------------------------------ body joints (the humanoid branch's block)
# One table per scheme for the trunk and limbs of both templates: the biped's chest and the humanoid's spine
# joints never meet in one rig.

# Per scheme: the trunk's names, and each limb joint's name with {S} for Left/Right and {s} for l/r.
_TRUNK_AND_LIMBS = {
    "mixamo": ({"hips": "Hips", "spine": "Spine", "chest": "Spine1", "spine1": "Spine1", "spine2": "Spine2",
                "neck": "Neck", "head": "Head", "head_end": "HeadTop_End"},
               {"clavicle": "{S}Shoulder", "shoulder": "{S}Arm", "elbow": "{S}ForeArm", "wrist": "{S}Hand",
                "hand_end": "{S}HandMiddle4", "hip": "{S}UpLeg", "knee": "{S}Leg", "ankle": "{S}Foot",
                "toe": "{S}ToeBase", "toe_end": "{S}Toe_End"}),
    "unity": ({"hips": "Hips", "spine": "Spine", "chest": "Chest", "spine1": "Chest", "spine2": "UpperChest",
               "neck": "Neck", "head": "Head", "head_end": "Head_End"},
              {"clavicle": "{S}Shoulder", "shoulder": "{S}UpperArm", "elbow": "{S}LowerArm", "wrist": "{S}Hand",
               "hand_end": "{S}Hand_End", "hip": "{S}UpperLeg", "knee": "{S}LowerLeg", "ankle": "{S}Foot",
               "toe": "{S}Toes", "toe_end": "{S}Toes_End"}),
    "unreal": ({"hips": "pelvis", "spine": "spine_01", "chest": "spine_03", "spine1": "spine_02",
                "spine2": "spine_03", "neck": "neck_01", "head": "head", "head_end": "head_end"},
               {"clavicle": "clavicle_{s}", "shoulder": "upperarm_{s}", "elbow": "lowerarm_{s}", "wrist": "hand_{s}",
                "hand_end": "hand_end_{s}", "hip": "thigh_{s}", "knee": "calf_{s}", "ankle": "foot_{s}",
                "toe": "ball_{s}", "toe_end": "ball_end_{s}"}),
}
_PREFIX = {"mixamo": "mixamorig:"}


def _body(scheme: str) -> dict[str, str]:
    """{template joint: the scheme's name} for the trunk and limbs of both templates."""
    trunk, limbs = _TRUNK_AND_LIMBS[scheme]
    names = dict(trunk)
    for side in SIDES:
        names.update({f"{side}_{joint}": name.format(S=side.capitalize(), s=side[0]) for joint, name in limbs.items()})
    return {joint: _PREFIX.get(scheme, "") + name for joint, name in names.items()}


_BODY = {scheme: _body(scheme) for scheme in _TRUNK_AND_LIMBS}
# ------------------------------------------------------------------ end of the body joints' block

# ---------------------------------------------------------------- fingers (autorig.hands), a block of its own
# A rig with fingers ({side}_{finger}1..3, _end: ``autorig.hands``) names them by the scheme's finger table
# (``hands.names``). Beside fingers, Mixamo's LeftHandMiddle4 is the middle finger's tip, so hand_end takes
# LeftHand_End instead; without fingers it keeps LeftHandMiddle4.

_EXTRA: dict[str, dict[str, str]] = {scheme: dict(FINGER_NAMES.get(scheme, {})) for scheme in _BODY}
# Names only a finger has: Mixamo's LeftHandMiddle4 is also the fingerless hand_end, so it says nothing.
_FINGER_WORDS = (set(finger_joint_names()).union(*(table.values() for table in FINGER_NAMES.values()))
                 - set().union(*(table.values() for table in _BODY.values())))


def _has_fingers(names) -> bool:
    """Whether joint names (the template's or any scheme's) include finger joints."""
    return any(name in _FINGER_WORDS for name in names)
# ---------------------------------------------------------------- end of the fingers' block

MIXAMO: dict[str, str] = {n: _BODY["mixamo"][n] for n in BIPED_JOINTS}   # the biped's, as before the humanoid


def scheme_names(scheme: str) -> dict[str, str]:
    """{template joint name: the scheme's name} for every joint the scheme names (both bodies' joints and the
    fingers)."""
    return {**_BODY[scheme], **_EXTRA[scheme]}


def _body_of(joint_names) -> tuple[str, ...] | None:
    """The body (``HUMANOID_JOINTS`` or ``BIPED_JOINTS``) whose joints ``joint_names`` all has, or None."""
    have = set(joint_names)
    return next((body for body in (HUMANOID_JOINTS, BIPED_JOINTS) if have.issuperset(body)), None)


def rename_joints(rig: Rig, scheme: str) -> Rig:
    """``rig`` with its joints named by ``scheme`` (one of ``NAME_SCHEMES``; "template" leaves it as it is).

    Raises ``TemplateError`` when the rig lacks any joint of the biped or of the humanoid, whose names every
    scheme knows; joints beyond them (a learned template's helper joints) keep their own names.
    """
    check_names(rig.names, scheme)
    if scheme == "template":
        return rig
    table = scheme_names(scheme)
    if _has_fingers(rig.names):
        table = {**table, **HAND_END_BESIDE_FINGERS.get(scheme, {})}
    return replace(rig, names=[table.get(name, name) for name in rig.names])


def check_names(joint_names: list[str], scheme: str) -> None:
    """Raise ``TemplateError`` unless joints called ``joint_names`` can be named by ``scheme``."""
    if scheme not in NAME_SCHEMES:
        raise TemplateError(f"unknown joint names {scheme!r}: choose one of {', '.join(NAME_SCHEMES)}")
    if scheme == "template" or _body_of(joint_names) is not None:
        return
    missing = [name for name in BIPED_JOINTS if name not in joint_names]
    raise TemplateError(f"--names {scheme}: {scheme} names the biped and humanoid templates' joints, and these "
                        f"joints are neither (no {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''})")


def template_names(names: list[str]) -> list[str]:
    """The template's names for joint names that may be any scheme's (others are returned as they are): the
    scheme and body that name most of ``names``, the biped on a tie (Mixamo's ``Spine1`` is the biped's chest
    unless a ``Spine2`` says the rig is the humanoid)."""
    best, best_count, fingered = {}, 0, _has_fingers(names)
    for scheme in _BODY:
        table = scheme_names(scheme)
        for body in (BIPED_JOINTS, HUMANOID_JOINTS):
            inverse = {table[joint]: joint for joint in body}
            if fingered:    # only then is Mixamo's LeftHandMiddle4 a fingertip rather than hand_end
                inverse.update({name: joint for joint, name in _EXTRA[scheme].items()})
                inverse.update({name: joint for joint, name in HAND_END_BESIDE_FINGERS.get(scheme, {}).items()})
            count = sum(name in inverse for name in names)
            if count > best_count:
                best, best_count = inverse, count
    return [best.get(name, name) for name in names]
