"""The hands stage of a rig: finger joints read off each hand (``read_fingers``) and bone heat with them
(``skin_with_fingers``); see the package's docstring (``autorig.hands``)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .digits import read_hand
from .joints import digit_joints
from .names import FINGERS, SIDES
from .region import CUT_BEFORE_WRIST, hand_piece, hand_surface, short_wrist_shift



@dataclass
class Fingers:
    """The finger joints added to a rig.

    names      [K] joint names ({side}_{finger}1, 2, 3, _end), parents before children
    parents    [K] each one's parent joint's name (the wrist for the first joint of each digit)
    positions  [K, 3] in the frame of the joints they were read with
    status     {side: "fingers" | "mitten" | "fist" | "unclear" | "too coarse"} for each side read
    palm_normals  {side: [3] unit normal out of the palm} for the sides with fingers
    pieces     {side: the hand's full-resolution piece of surface (``region.hand_piece``)} for the sides with
               fingers, kept for their weights (``skin_with_fingers``) rather than cut out of the mesh again
    moved      {side: [3] offset} by which the side's wrist and hand_end move: the sides whose arm stopped short
               of the hand (``region.short_wrist_shift``) and whose hand read right from the wrist moved there
    """
    names: list[str] = field(default_factory=list)
    parents: list[str] = field(default_factory=list)
    positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    status: dict[str, str] = field(default_factory=dict)
    palm_normals: dict[str, np.ndarray] = field(default_factory=dict)
    pieces: dict = field(default_factory=dict)
    moved: dict = field(default_factory=dict)

    def moved_joints(self, names, joints) -> np.ndarray:
        """joints [J, 3] of the rig's ``names`` [J] with each ``moved`` side's wrist and hand_end moved (a copy)."""
        joints = np.array(joints, dtype=np.float64)
        for side, offset in self.moved.items():
            for joint in ("wrist", "hand_end"):
                joints[list(names).index(f"{side}_{joint}")] += offset
        return joints

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

    An arm whose end stops short of its hand (the limb reaches on well past the wrist) is read again from a
    wrist moved out to the hand (``region.short_wrist_shift``); when the hand reads right from there, that
    wrist is the one its fingers hang from, and ``Fingers.moved`` says how far the rig's wrist and hand_end go.
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
        shift = short_wrist_shift(vertices, faces, wrist, elbow, surface.piece)
        if shift > 0:
            offset = shift * surface.axis
            there = hand_surface(vertices, faces, wrist + offset, elbow)
            again = read_hand(there, side) if there is not None else None
            if again is not None and again.status == "fingers":     # else the limb went on past a hand
                wrist, surface, reading = wrist + offset, there, again
                out.moved[side] = offset
        out.status[side] = reading.status
        if reading.status != "fingers":
            continue
        out.palm_normals[side] = reading.palm_normal
        out.pieces[side] = surface.piece
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


def skin_with_fingers(vertices, faces, joints, parents, names, fingers: Fingers, surface=None,
                      height=None) -> np.ndarray:
    """Bone-heat weights [V, J + K] of the rig's J joints (joints [J, 3], parents [J], names [J]) and the K
    finger joints (``read_fingers``); rows >= 0 summing to 1, every vertex weighted.

    The body is heated as without fingers. Each hand with fingers is then heated again on its own, at the
    full resolution of its piece of surface (``region.hand_piece``), with the forearm, the palm's bones (the
    wrist to each digit's first joint, the wrist's) and the finger bones: each finger's skin follows that
    finger. The hand's weights replace the body's from the wrist on, blended smoothly over the forearm
    between the cut and the wrist, where both solutions agree on the forearm. The body's solve keeps its
    size (a 30k-face character: one solve of 23 bones, not of 63), and the fingers get the hand's
    triangles rather than the body's simplified copy. ``surface``: the body's heat surface made beforehand, as
    ``attach.bone_heat`` takes it (None: made here); ``height``: the character's, as ``bone_heat`` takes it
    (separate pieces, a nail on a finger, take the weights of the body they sit on: ``autorig.weights.pieces``)."""
    from ..weights.attach import bone_heat, weld_surface
    from ..weights.pieces import follow_body

    names = list(names)
    weights = np.hstack([bone_heat(vertices, faces, joints, parents, surface=surface, height=height),
                         np.zeros((len(vertices), len(fingers.names)))])
    column = {n: i for i, n in enumerate(names + fingers.names)}
    for side, status in fingers.status.items():
        if status != "fingers":
            continue
        wrist, elbow = joints[column[f"{side}_wrist"]], joints[column[f"{side}_elbow"]]
        piece = fingers.pieces.get(side) or hand_piece(vertices, faces, wrist, elbow)
        if piece is None:       # not for the mesh the fingers were read off: keep the body's weights
            continue
        own = [k for k, n in enumerate(fingers.names) if n.startswith(f"{side}_")]
        local_names = [f"{side}_elbow", f"{side}_wrist"] + [fingers.names[k] for k in own]
        local_index = {n: i for i, n in enumerate(local_names)}
        local_parents = [-1, 0] + [local_index[fingers.parents[k]] for k in own]
        local_joints = np.vstack([elbow, wrist, fingers.positions[own]])
        hand = bone_heat(piece.vertices, piece.faces, local_joints, local_parents, height=height)  # [N, 2 + 20]
        # Input vertices of the piece (their welded copy is in it), and how far past the cut each lies.
        slot = np.full(int(piece.weld.max()) + 1, -1)
        slot[piece.ids] = np.arange(len(piece.ids))
        rows = np.flatnonzero(slot[piece.weld] >= 0)
        at = slot[piece.weld[rows]]
        cut = -CUT_BEFORE_WRIST * float(np.linalg.norm(wrist - elbow))
        s = np.clip((piece.along[at] - cut) / -cut, 0.0, 1.0)
        s = (s * s * (3 - 2 * s))[:, None]
        local = np.zeros((len(rows), weights.shape[1]))
        local[:, [column[n] for n in local_names]] = hand[at]
        weights[rows] = (1 - s) * weights[rows] + s * local
    # The hand's piece is the surface joined to the wrist: nails and rings apart from it take the weights of
    # the finger they sit on now that the fingers have theirs.
    weld, Vw, Fw = weld_surface(np.asarray(vertices, np.float64), np.asarray(faces, np.int64))
    first = np.unique(weld, return_index=True)[1]
    return follow_body(Vw, Fw, weights[first], height)[weld]


__all__ = ["FINGERS", "Fingers", "SIDES", "has_hands", "read_fingers", "skin_with_fingers"]
