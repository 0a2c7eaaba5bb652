"""Move a rig: retarget a BVH motion onto its joints and deform its mesh.

    from autorig.exchange.bvh import read_bvh
    from autorig.show.pose import retarget, skin
    animation = retarget(rig, read_bvh("walk.bvh"))          # rig joints over time
    posed = skin(rig, animation.rotations[10], animation.positions[10])   # [V, 3] mesh at frame 10

Retargeting copies world-space bone directions. Both skeletons are first put in one frame (the rig's up/front
from ``rig.info`` or the caller; the motion's up and left inferred from its rest pose), then for each mapped
rig joint j (BVH joint b) a fixed alignment A_j is found that turns b's rest bones onto j's rest bones (the
best-fit rotation over j's mapped children, preferring no twist when they leave it undetermined). In every
frame j's world rotation is then G_b(t) A_j^T, where G_b(t) is b's world rotation away from the motion's rest
pose: a rig bone points where the matching motion bone points, whatever pose (T, A, legs apart) either
skeleton was built in, and bone lengths stay the rig's. Unmapped rig joints move rigidly with their parent.
Bones that stand upright in both rest poses (a spine, a neck, a head: within ``UPRIGHT_CONE`` of up) are
the exception: both skeletons stand upright at rest, and what separates their directions there is build (a
capture's head leaning two degrees forward), not pose, so the rig's rest maps to the motion's rest and the
bone takes the motion's turn away from its rest, G_b(t): a clip's head that nods 10 degrees nods the rig's
head 10 degrees from its own upright rest, and a walker turning round turns it about the vertical (blended
linearly to world directions across the cone's edge, G_b(t) A_j^T A_j^w, so that the motion stays
continuous in both rest poses).

The root is placed by the motion's root, scaled by the ratio of the two hip heights (hips above the ground with
the legs straight), its first frame's ground position put under the rig's rest root, and the motion's ground
taken to be its up = 0 plane, as in CMU and mixamo files.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..exchange.bvh import Motion
from ..hands.names import motion_names as finger_motion_names
from ..input.mesh import frame_rotation
from ..naming import template_names
from ..result import Rig

__all__ = ["BIPED_MAP", "Animation", "joint_map", "read_map", "retarget", "skin"]


def _biped_map() -> dict[str, tuple[str, ...]]:
    """Biped template joint -> motion joint names to look for, first found wins.

    Names are compared after dropping any namespace prefix ("mixamorig:LeftArm" -> "LeftArm"). CMU (cgspeed
    BVH) and mixamo share most names; the upper arm is LeftArm in both (their LeftShoulder is the collarbone),
    while MotionBuilder-style files (Hips/Ab/Chest/LeftCollar/LeftShoulder/LeftElbow) call the upper arm
    LeftShoulder: hence LeftArm before LeftShoulder.
    """
    table = {
        "hips": ("Hips", "Hip", "pelvis", "Pelvis"),
        "spine": ("Spine", "Ab", "LowerBack", "spine_01"),
        "chest": ("Spine2", "Spine1", "Chest", "Chest2"),
        # the humanoid's three spine joints (templates/humanoid.json): Mixamo's, CMU's, Unity's, Unreal's
        "spine1": ("Spine1", "Chest", "spine_02"),
        "spine2": ("Spine2", "Chest2", "UpperChest", "spine_03"),
        "neck": ("Neck", "Neck1", "neck_01"),
        "head": ("Head",),
        "head_end": ("HeadTop_End",),
    }
    for side, s in (("left", "L"), ("right", "R")):
        S = side.capitalize()
        table.update({
            f"{side}_shoulder": (f"{S}Arm", f"{S}UpArm", f"{S}Shoulder"),
            # the humanoid's collarbone, after the arm: a MotionBuilder-style file's LeftCollar (its LeftShoulder
            # is the upper arm), else Mixamo's and CMU's LeftShoulder (``joint_map`` keeps it off a joint the arm
            # took)
            f"{side}_clavicle": (f"{S}Collar", f"clavicle_{s.lower()}", f"{S}Shoulder"),
            f"{side}_elbow": (f"{S}ForeArm", f"{S}Elbow", f"{S}LowArm"),
            f"{side}_wrist": (f"{S}Hand", f"{S}Wrist"),
            f"{side}_hand_end": (f"{S}HandMiddle1", f"{S}HandIndex1", f"{s}Fingers", f"{S}FingerBase"),
            f"{side}_hip": (f"{S}UpLeg", f"{S}Hip", f"{S}Thigh"),
            f"{side}_knee": (f"{S}Leg", f"{S}Knee", f"{S}Shin", f"{S}LowLeg"),
            f"{side}_ankle": (f"{S}Foot", f"{S}Ankle"),
            f"{side}_toe": (f"{S}ToeBase", f"{S}Toes", f"{S}Toe"),
            f"{side}_toe_end": (f"{S}Toe_End",),
        })
    table.update(finger_motion_names())   # a rig with fingers (autorig.hands): Mixamo's and Unreal's finger bones
    return table


BIPED_MAP: dict[str, tuple[str, ...]] = _biped_map()

# Weight of the "frames already agree" prior in each joint's alignment: only decides what the bones leave free
# (the twist about a single bone, or about a line of collinear ones), never overrides them.
_PRIOR = 1e-6
# Degrees from up: bones within the first angle in both rest poses (a standing spine, neck, head) copy the
# motion's turn away from its rest; beyond the second, world directions; linear in between.
UPRIGHT_CONE = (20.0, 35.0)


@dataclass
class Animation:
    """A rig's joints over time.

    times      [N] seconds
    rotations  [N, J, 3, 3] each joint's world rotation away from the rig's rest pose: a point p that follows
               joint j goes to rotations[t, j] @ (p - rig.joints[j]) + positions[t, j]
    positions  [N, J, 3] each joint's position, in the rig's coordinates and units
    local      [N, J, 3, 3] each joint's rotation relative to its parent's (what a glTF node's rotation is,
               since the rig's rest pose has no rotations)
    mapping    {rig joint name: motion joint name} used
    """
    times: np.ndarray
    rotations: np.ndarray
    positions: np.ndarray
    local: np.ndarray
    mapping: dict[str, str]

    @property
    def animated(self) -> np.ndarray:
        """[J] bool: joints whose local rotation is not the identity in some frame."""
        return np.abs(self.local - np.eye(3)).max(axis=(0, 2, 3)) > 1e-9


def read_map(path: str | os.PathLike) -> dict[str, str | None]:
    """A joint map file: a JSON object {rig joint name: motion joint name, or null to leave it unmapped}."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None
    except ValueError as e:
        raise InputError(f"{path}: not JSON: {e}") from None
    if not isinstance(data, dict) or not all(isinstance(v, (str, type(None))) for v in data.values()):
        raise InputError(f"{path}: expected an object {{rig joint: motion joint or null}}")
    return data


def joint_map(rig_names: list[str], motion_names: list[str], overrides: dict[str, str | None] | None = None
              ) -> dict[str, str]:
    """{rig joint: motion joint}: the built-in table where it finds names, then ``overrides`` on top.

    Raises ``InputError`` if an override names a joint that neither skeleton has.
    """
    by_bare = {}
    for name in motion_names:
        by_bare.setdefault(_bare(name), name)
    # A rig written with --names mixamo maps as the biped it is.
    rig_joint = dict(zip(template_names(rig_names), rig_names))
    mapping = {}
    for joint, candidates in BIPED_MAP.items():
        found = next((by_bare[c] for c in candidates if c in by_bare), None)
        if joint in rig_joint and found is not None and found not in mapping.values():
            mapping[rig_joint[joint]] = found
    for joint, target in (overrides or {}).items():
        if joint not in rig_names:
            raise InputError(f"the joint map names {joint!r}, which the rig does not have "
                             f"(it has {', '.join(rig_names)})")
        if target is None:
            mapping.pop(joint, None)
            continue
        if target not in motion_names and target not in by_bare:
            raise InputError(f"the joint map names {target!r}, which the motion does not have")
        mapping[joint] = target if target in motion_names else by_bare[target]
    return mapping


def _bare(name: str) -> str:
    return name.rsplit(":", 1)[-1]


def retarget(rig: Rig, motion: Motion, mapping: dict[str, str] | None = None, up: str | None = None,
             front: str | None = None) -> Animation:
    """Retarget ``motion`` onto ``rig`` (see the module docstring).

    mapping    {rig joint: motion joint}; default ``joint_map(rig.names, motion.names)``
    up, front  the rig's axes (x|y|z|-x|-y|-z); default ``rig.info``'s, else y and z
    Raises ``InputError`` if the rig's root joint has no motion joint.
    """
    mapping = joint_map(rig.names, motion.names) if mapping is None else mapping
    parents = np.asarray(rig.parents)
    rest = np.asarray(rig.joints, dtype=np.float64)
    J = len(rig.names)
    root = int(np.flatnonzero(parents < 0)[0])
    if rig.names[root] not in mapping:
        raise InputError(f"cannot retarget: the rig's root joint {rig.names[root]!r} has no motion joint; "
                         f"map it with a joint map file")
    source = {j: motion.names.index(mapping[name]) for j, name in enumerate(rig.names) if name in mapping}

    rig_frame = frame_rotation(up or rig.info.get("up", "y"), front or rig.info.get("front", "z"))
    motion_frame = _motion_frame(motion, template_names(rig.names), source)
    to_rig = rig_frame.T @ motion_frame  # motion-space vectors -> rig-space vectors
    motion_rest = motion.rest_positions() @ to_rig.T
    motion_r, motion_p = motion.world_transforms()
    motion_r = to_rig @ motion_r @ to_rig.T
    N = len(motion.frames)

    align = np.tile(np.eye(3), (J, 1, 1))
    rotations = np.empty((N, J, 3, 3))
    for j in range(J):
        p = parents[j]
        if j in source:
            pairs = _pairs(j, source, rig, motion, motion_rest, to_rig)
            align[j] = _alignment(pairs, align[p] if p >= 0 else np.eye(3))
            rotations[:, j] = motion_r[:, source[j]] @ align[j].T @ _rest_to_rest(align[j], _upright(pairs,
                                                                                              rig_frame[1]))
        else:
            align[j] = align[p] if p >= 0 else np.eye(3)
            rotations[:, j] = rotations[:, p] if p >= 0 else np.eye(3)

    up_rig = rig_frame[1]
    up_motion = motion_frame[1]
    scale = _hip_height(rig, up_rig) / _motion_hip_height(motion, mapping, up_motion)
    ground = float(np.min(np.asarray(rig.vertices) @ up_rig))
    start = rest[root] - (rest[root] @ up_rig - ground) * up_rig      # the rig's root, dropped to its ground
    root_path = motion_p[:, source[root]]
    origin = root_path[0] - (root_path[0] @ up_motion) * up_motion    # the motion's first root, on its ground
    positions = np.empty((N, J, 3))
    positions[:, root] = start + scale * (root_path - origin) @ to_rig.T
    for j in range(J):
        p = parents[j]
        if p >= 0:
            positions[:, j] = positions[:, p] + rotations[:, p] @ (rest[j] - rest[p])

    local = rotations.copy()
    has_parent = parents >= 0
    local[:, has_parent] = np.swapaxes(rotations[:, parents[has_parent]], -1, -2) @ rotations[:, has_parent]
    return Animation(times=motion.times, rotations=rotations, positions=positions, local=local,
                     mapping={rig.names[j]: motion.names[b] for j, b in source.items()})


def _pairs(j: int, source: dict[int, int], rig: Rig, motion: Motion, motion_rest: np.ndarray,
           to_rig: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(rig rest bone [3], motion rest bone [3])] of rig joint j and motion joint source[j], in the rig's frame.

    The bones are those to j's mapped children; if it has none but j has one child and the motion joint one
    continuation (a single child joint or an End Site), that pair. Zero-length bones are left out.
    """
    rest = np.asarray(rig.joints, dtype=np.float64)
    children = [int(c) for c in np.flatnonzero(np.asarray(rig.parents) == j)]
    b = source[j]
    pairs = [(rest[c] - rest[j], motion_rest[source[c]] - motion_rest[b]) for c in children if c in source]
    if not pairs and len(children) == 1:
        ends = [motion.offsets[c] for c in motion.children(b)] + ([motion.end_sites[b]] if b in motion.end_sites
                                                                  else [])
        if len(ends) == 1:
            pairs = [(rest[children[0]] - rest[j], to_rig @ ends[0])]
    return [(r, m) for r, m in pairs if np.linalg.norm(r) > 1e-12 and np.linalg.norm(m) > 1e-12]


def _alignment(pairs: list[tuple[np.ndarray, np.ndarray]], inherited: np.ndarray) -> np.ndarray:
    """Rotation [3, 3] taking the motion's rest bones onto the rig's (``_pairs``), preferring no twist where
    they leave it free; without bones, ``inherited`` (the parent's alignment), so the joint keeps the parent's
    correspondence."""
    if not pairs:
        return inherited
    H = _PRIOR * np.eye(3)
    for r, m in pairs:
        H += np.outer(r / np.linalg.norm(r), m / np.linalg.norm(m))
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def _upright(pairs: list[tuple[np.ndarray, np.ndarray]], up: np.ndarray) -> float:
    """How much a joint's bones stand upright in both rest poses, 0 to 1: 1 when every bone of ``pairs``, the
    rig's and the motion's, is within ``UPRIGHT_CONE[0]`` degrees of ``up``, 0 when one is ``UPRIGHT_CONE[1]``
    or more away, linear in the widest angle between (continuous in the rest poses)."""
    if not pairs:
        return 0.0
    cosines = [v @ up / np.linalg.norm(v) for pair in pairs for v in pair]
    widest = float(np.degrees(np.arccos(np.clip(min(cosines), -1.0, 1.0))))
    lo, hi = UPRIGHT_CONE
    return float(np.clip((hi - widest) / (hi - lo), 0.0, 1.0))


def _rest_to_rest(align: np.ndarray, amount: float) -> np.ndarray:
    """``amount`` [3, 3] of ``align`` (a joint's alignment), by angle about its axis, undoing that much of it
    before the motion's rotation: 1, the rig's rest maps to the motion's rest (the joint turns by the motion's
    own rotation); 0, world directions copied."""
    if amount <= 0.0:
        return np.eye(3)
    from scipy.spatial.transform import Rotation
    return Rotation.from_rotvec(amount * Rotation.from_matrix(align).as_rotvec()).as_matrix()


def _motion_frame(motion: Motion, rig_names: list[str], source: dict[int, int]) -> np.ndarray:
    """Rows: the motion's left, up and front as signed coordinate axes [3, 3], read off its rest pose.

    Up is from the root towards the mapped head (or neck, chest, spine), left from the right hip (or
    shoulder) to the left one; each is snapped to the nearest axis, as motion files are authored on axes.
    Without those joints the motion is taken to be +y up, +z front, as BVH files almost always are.
    """
    rest = motion.rest_positions()
    at = {rig_names[j]: rest[b] for j, b in source.items()}
    root = at.get("hips", rest[0])
    up = next((at[n] - root for n in ("head", "neck", "chest", "spine") if n in at), None)
    left = next((at["left_" + n] - at["right_" + n] for n in ("hip", "shoulder", "knee", "elbow")
                 if "left_" + n in at and "right_" + n in at), None)
    if up is None or left is None or np.linalg.norm(up) == 0 or np.linalg.norm(left) == 0:
        return np.eye(3)
    up, left = _snap(up), _snap(left)
    if abs(up @ left) > 0.5:
        return np.eye(3)
    return np.array([left, up, np.cross(left, up)])


def _snap(v: np.ndarray) -> np.ndarray:
    axis = int(np.argmax(np.abs(v)))
    out = np.zeros(3)
    out[axis] = np.sign(v[axis])
    return out


def _hip_height(rig: Rig, up: np.ndarray) -> float:
    """The rig's hips above its lowest vertex with straight legs (see ``_leg_height``)."""
    rest = np.asarray(rig.joints, dtype=np.float64)
    ground = float(np.min(np.asarray(rig.vertices) @ up))
    at = {name: rest[j] for j, name in enumerate(template_names(rig.names))}
    root = rest[int(np.flatnonzero(np.asarray(rig.parents) < 0)[0])]
    return _leg_height(at, root, up, ground)


def _motion_hip_height(motion: Motion, mapping: dict[str, str], up: np.ndarray) -> float:
    """The motion skeleton's hips above its lowest rest point with straight legs (see ``_leg_height``)."""
    rest = motion.rest_positions()
    points = [rest] + [rest[b] + offset for b, offset in motion.end_sites.items()]
    ground = float(np.min(np.vstack(points) @ up))
    at = {joint: rest[motion.names.index(name)] for joint, name in zip(template_names(list(mapping)),
                                                                         mapping.values())}
    return _leg_height(at, at.get("hips", rest[0]), up, ground)


def _leg_height(at: dict[str, np.ndarray], root: np.ndarray, up: np.ndarray, ground: float) -> float:
    """Height [scalar] of ``root`` above ``ground`` if the legs hung straight down: the root's drop to the hip
    joint, plus thigh and shin lengths, plus the ankle's height; averaged over the legs that ``at`` ({joint
    name: position}) holds. With no complete leg, the root's height above the ground as it stands.

    Rest poses differ (CMU's legs stand apart, a rig's may be bent), so measured heights would not compare.
    """
    heights = []
    for side in ("left", "right"):
        chain = [at.get(f"{side}_{n}") for n in ("hip", "knee", "ankle")]
        if all(p is not None for p in chain):
            hip, knee, ankle = chain
            heights.append((root - hip) @ up + np.linalg.norm(knee - hip) + np.linalg.norm(ankle - knee)
                           + ankle @ up - ground)
    height = float(np.mean(heights)) if heights else float(root @ up - ground)
    if not height > 0:
        raise InputError("cannot tell the hip height of the skeleton: its root is not above its lowest point")
    return height


def skin(rig: Rig, rotations: np.ndarray, positions: np.ndarray, dqs: bool = False) -> np.ndarray:
    """The rig's mesh posed: vertices [V, 3].

    rotations  [J, 3, 3] each joint's world rotation away from the rest pose (``Animation.rotations[t]``)
    positions  [J, 3] each joint's posed position (``Animation.positions[t]``)
    dqs        dual quaternion skinning instead of linear blend skinning: no "candy wrapper" collapse of
               twisted joints, at the cost of a little bulging at bends
    """
    weights = np.asarray(rig.weights, dtype=np.float64)
    vertices = np.asarray(rig.vertices, dtype=np.float64)
    rest = np.asarray(rig.joints, dtype=np.float64)
    translations = positions - np.einsum("jab,jb->ja", rotations, rest)   # joint j: v -> R v + t
    if not dqs:
        blended = weights @ np.concatenate([rotations.reshape(-1, 9), translations], axis=1)  # [V, 12]
        return np.einsum("vab,vb->va", blended[:, :9].reshape(-1, 3, 3), vertices) + blended[:, 9:]

    from scipy.spatial.transform import Rotation

    real = Rotation.from_matrix(rotations).as_quat()                     # [J, 4] x y z w
    dual = 0.5 * _quat_mul(np.concatenate([translations, np.zeros((len(rest), 1))], axis=1), real)
    # q and -q are one rotation; blend each vertex's joints on the hemisphere of its strongest one.
    signs = np.sign(real @ real.T)[np.argmax(weights, axis=1)]         # [V, J]
    signs[signs == 0] = 1.0
    w = weights * signs
    b_real, b_dual = w @ real, w @ dual                                 # [V, 4]
    norm = np.linalg.norm(b_real, axis=1, keepdims=True)
    b_real, b_dual = b_real / norm, b_dual / norm
    rotated = Rotation.from_quat(b_real).apply(vertices)
    conj = b_real * np.array([-1.0, -1.0, -1.0, 1.0])
    return rotated + 2.0 * _quat_mul(b_dual, conj)[:, :3]


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products [N, 4] of quaternions a, b [N, 4] (x, y, z, w; either may be one row)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)
