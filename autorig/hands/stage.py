"""The hands stage of a rig: finger joints read off each hand (``read_fingers``) and bone heat with them
(``skin_with_fingers``); see the package's docstring (``autorig.hands``)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .digits import read_hand
from .joints import digit_joints
from .names import FINGERS, SIDES
from .region import hand_surface



@dataclass
class Fingers:
    """The finger joints added to a rig.

    names      [K] joint names ({side}_{finger}1, 2, 3, _end), parents before children
    parents    [K] each one's parent joint's name (the wrist for the first joint of each digit)
    positions  [K, 3] in the frame of the joints they were read with
    status     {side: "fingers" | "mitten" | "fist" | "unclear" | "too coarse"} for each side read
    palm_normals  {side: [3] unit normal out of the palm} for the sides with fingers
    """
    names: list[str] = field(default_factory=list)
    parents: list[str] = field(default_factory=list)
    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    status: dict[str, str] = field(default_factory=dict)
    palm_normals: dict[str, np.ndarray] = field(default_factory=dict)

    def appended(self, names, parents, joints, weights):
        """(names [J + K], parents [J + K], joints [J + K, 3], weights [V, J + K]) of a rig's J joints with
        these fingers after them; ``weights`` [V, J + K] already holds the fingers' columns last."""
        names = list(names)
        index = {n: i for i, n in enumerate(names + self.names)}
        parents = np.concatenate([np.asarray(parents, np.int64),
                                  np.array([index[p] for p in self.parents], np.int64)])
        return names + self.names, parents, np.vstack([joints, self.positions]), weights

    def info(self) -> dict:
        """What a rig's ``info`` says of its hands: {"hands": {side: status}}."""
        return {"hands": dict(self.status)}


def has_hands(names) -> list[str]:
    """The sides ("left", "right") whose wrist, elbow and hand_end are among ``names``."""
    return [s for s in SIDES if all(f"{s}_{j}" in names for j in ("wrist", "elbow", "hand_end"))]


def read_fingers(vertices, faces, names, joints) -> Fingers:
    """Finger joints of each hand of a rig, read off its mesh.

    vertices [V, 3], faces [F, 3]: the mesh at full resolution; names [J]: the rig's joint names; joints
    [J, 3]: their positions, in the mesh's frame. Returns ``Fingers`` (empty for a rig without hands).
    """
    index = {n: i for i, n in enumerate(names)}
    out = Fingers()
    rows = []
    for side in has_hands(names):
        wrist, elbow = joints[index[f"{side}_wrist"]], joints[index[f"{side}_elbow"]]
        surface = hand_surface(vertices, faces, wrist, elbow)
        if surface is None:
            out.status[side] = "too coarse"
            continue
        reading = read_hand(surface, side)
        out.status[side] = reading.status
        if reading.status != "fingers":
            continue
        out.palm_normals[side] = reading.palm_normal
        for finger, chain in digit_joints(surface, reading, wrist).items():
            parent = f"{side}_wrist"
            for k, point in enumerate(chain):
                name = f"{side}_{finger}{k + 1}" if k < 3 else f"{side}_{finger}_end"
                out.names.append(name)
                out.parents.append(parent)
                rows.append(point)
                parent = name
    out.positions = np.array(rows, dtype=np.float64).reshape(-1, 3)
    return out


def skin_with_fingers(vertices, faces, joints, parents, names, fingers: Fingers) -> np.ndarray:
    """Bone-heat weights [V, J + K] of the rig's J joints (joints [J, 3], parents [J], names [J]) and the K
    finger joints. Each finger's bones heat its own skin; the palm follows the wrist.

    The wrist's bone to ``hand_end`` would run down the middle finger and warm it for the wrist; with fingers
    it is heated from the middle finger's knuckle instead (the bone wrist -> middle1, which the wrist owns
    anyway), while ``hand_end`` itself stays where the body's rig put it."""
    from ..attach import bone_heat

    heat_joints = np.array(joints, dtype=np.float64)
    index = {n: i for i, n in enumerate(list(names) + fingers.names)}
    all_joints = np.vstack([heat_joints, fingers.positions])
    for side, status in fingers.status.items():
        if status == "fingers":
            all_joints[index[f"{side}_hand_end"]] = all_joints[index[f"{side}_middle1"]]
    _, all_parents, _, _ = fingers.appended(names, parents, all_joints, None)
    return bone_heat(vertices, faces, all_joints, all_parents)


__all__ = ["FINGERS", "Fingers", "SIDES", "has_hands", "read_fingers", "skin_with_fingers"]
