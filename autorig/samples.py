"""Procedural sample characters whose skeletons are known exactly: the README sample and test fixtures.

    from autorig.samples import mannequin, quadruped
    s = mannequin(pose="a", proportions="child")
    s.vertices, s.faces, s.joints["left_elbow"]

Each character is an implicit surface: a smooth union of tapered capsules and ellipsoids laid along the bones
of a skeleton that is built first, sampled on a regular grid and meshed with marching cubes. Because every
limb primitive runs from one joint to the next, each joint sits on the axis of the limb at the bend, which is
what a rigger should find; the joints returned are that skeleton, so they are ground truth for joint placement.

Frame and units: +y up, +z the way the character faces, +x its own left, soles at y = 0; metres at natural
size (a 1.70 m adult, a dog 0.6 m at the withers), not normalised to the templates' unit height.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import reduce

import mcubes
import numpy as np


@dataclass(frozen=True)
class Sample:
    """A watertight character mesh and the skeleton it was built around.

    vertices  [V, 3] float64 vertex positions (metres, +y up, +z front, +x the character's left)
    faces     [F, 3] int64 vertex indices of triangles wound counter-clockwise seen from outside; together
              one closed, manifold, connected surface
    joints    template joint name -> [3] float64 position; covers every joint of the template, the ``*_end``
              tips included (tips lie on the surface or just inside it, all other joints well inside)
    template  name of the built-in template the joints follow ("biped" or "quadruped")
    """
    vertices: np.ndarray
    faces: np.ndarray
    joints: dict[str, np.ndarray]
    template: str


@dataclass(frozen=True)
class Proportions:
    """Body measurements of a mannequin, in metres.

    height          soles to crown
    head            chin to crown
    leg             soles to the hip joints (the tops of the thighs)
    hip_width       between the two hip joints
    shoulder_width  between the two shoulder joints
    arm             shoulder joint to fingertip along the straight arm
    girth           multiplies the widths of the torso and limbs (1 = slim adult)
    """
    height: float = 1.70
    head: float = 0.23
    leg: float = 0.88
    hip_width: float = 0.18
    shoulder_width: float = 0.35
    arm: float = 0.74
    girth: float = 1.0


PROPORTIONS = {
    "adult": Proportions(),
    "child": Proportions(height=1.20, head=0.205, leg=0.58, hip_width=0.13, shoulder_width=0.24, arm=0.50,
                         girth=1.1),
    "heavy": Proportions(height=1.75, head=0.235, leg=0.89, hip_width=0.22, shoulder_width=0.40, arm=0.76,
                         girth=1.35),
    "tall": Proportions(height=1.95, head=0.245, leg=1.04, hip_width=0.19, shoulder_width=0.39, arm=0.86,
                        girth=0.95),
}


@dataclass(frozen=True)
class QuadrupedProportions:
    """Body measurements of a four-legged animal, in metres.

    shoulder_height  ground to the front shoulder joints
    body             front shoulder joints to back hip joints, along z
    head             base of the skull to the tip of the nose
    tail             tail base to tail tip
    girth            multiplies the widths of the body and legs (1 = a lean medium-sized dog)
    """
    shoulder_height: float = 0.42
    body: float = 0.50
    head: float = 0.26
    tail: float = 0.36
    girth: float = 1.0


QUADRUPED_PROPORTIONS = {
    "dog": QuadrupedProportions(),
    "long": QuadrupedProportions(shoulder_height=0.17, body=0.42, head=0.21, tail=0.24, girth=0.8),
    "tall": QuadrupedProportions(shoulder_height=0.62, body=0.55, head=0.30, tail=0.42, girth=0.95),
}

# Arm direction in the character's left x-y plane, as degrees below horizontal ("down" is worked out per body).
_ARM_DROP = {"t": 0.0, "a": 45.0}


def mannequin(pose: str = "t", proportions: str | Proportions = "adult", resolution: int = 88) -> Sample:
    """A human mannequin standing upright, facing +z, with the biped template's joints.

    pose         "t" (arms horizontal), "a" (arms 45 degrees down) or "down" (arms hanging beside the body
                 with a small gap to it)
    proportions  a name from ``PROPORTIONS`` or a ``Proportions``
    resolution   grid cells along the longest side of the bounding box; the default gives 10k-16k faces.
                 Below about 64 the thinnest parts (fingertips, toes, tail) can break off or vanish.
    """
    p = _lookup(PROPORTIONS, proportions)
    if pose != "down" and pose not in _ARM_DROP:
        raise ValueError(f"unknown pose {pose!r}; expected 't', 'a' or 'down'")
    joints, shapes = _biped(p, pose)
    vertices, faces = _mesh(shapes, blend=0.025 * p.height / 1.70, resolution=resolution)
    return Sample(vertices, faces, joints, "biped")


def quadruped(proportions: str | QuadrupedProportions = "dog", resolution: int = 88) -> Sample:
    """A dog-like animal standing on all fours, facing +z, with the quadruped template's joints.

    proportions  a name from ``QUADRUPED_PROPORTIONS`` or a ``QuadrupedProportions``
    resolution   grid cells along the longest side of the bounding box (see ``mannequin``)
    """
    p = _lookup(QUADRUPED_PROPORTIONS, proportions)
    joints, shapes = _quadruped(p)
    vertices, faces = _mesh(shapes, blend=0.02 * p.body / 0.50, resolution=resolution)
    return Sample(vertices, faces, joints, "quadruped")


def _lookup(table: dict, proportions):
    if not isinstance(proportions, str):
        return proportions
    if proportions not in table:
        raise ValueError(f"unknown proportions {proportions!r}; expected one of {', '.join(table)}")
    return table[proportions]


# ---------------------------------------------------------------------------------------------------------
# Primitives. Each gives a signed distance-like value (negative inside) for [P, 3] points; only the sign and a
# roughly metric scale near the surface matter, since the surface is the zero level set of their smooth union.

@dataclass(frozen=True)
class _Cone:
    """Tapered capsule: radius ``ra`` at ``a`` changing linearly to ``rb`` at ``b``, with round ends."""
    a: np.ndarray
    b: np.ndarray
    ra: float
    rb: float

    def distance(self, points: np.ndarray) -> np.ndarray:
        ab = self.b - self.a
        t = np.clip((points - self.a) @ ab / (ab @ ab), 0.0, 1.0)
        return np.linalg.norm(points - (self.a + t[:, None] * ab), axis=1) - (self.ra + t * (self.rb - self.ra))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        r = max(self.ra, self.rb)
        return np.minimum(self.a, self.b) - r, np.maximum(self.a, self.b) + r


@dataclass(frozen=True)
class _Ellipsoid:
    """Ellipsoid at ``centre`` with semi-axes ``radii`` [3] along the rows of ``axes`` [3, 3] (orthonormal)."""
    centre: np.ndarray
    radii: np.ndarray
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))

    def distance(self, points: np.ndarray) -> np.ndarray:
        # Quilez's approximation: exact on the surface and close to metric near it, unlike |q/r| - 1 whose
        # slope differs between the long and short axes and so would blend them unevenly.
        q = (points - self.centre) @ self.axes.T
        k0 = np.linalg.norm(q / self.radii, axis=1)
        k1 = np.linalg.norm(q / self.radii ** 2, axis=1)
        # At the centre the formula is 0/0; the depth there is the shortest semi-axis.
        return np.where(k1 > 1e-12, k0 * (k0 - 1.0) / np.maximum(k1, 1e-12), -self.radii.min())

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        half = np.abs(self.axes.T) @ self.radii
        return self.centre - half, self.centre + half


def _smooth_min(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum: equals min(a, b) wherever |a - b| >= k, so blends stay local to the seams."""
    h = np.clip(k - np.abs(a - b), 0.0, None) / k
    return np.minimum(a, b) - h * h * k / 4.0


def _mesh(shapes: list, blend: float, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the smooth union of ``shapes`` with marching cubes; returns vertices [V, 3] and faces [F, 3]."""
    lo = np.min([s.bounds()[0] for s in shapes], axis=0)
    hi = np.max([s.bounds()[1] for s in shapes], axis=0)
    step = (hi - lo).max() / resolution
    # Two empty cells of margin keep the surface off the grid border, so marching cubes closes it.
    lo -= 2 * step
    counts = np.ceil((hi - lo) / step).astype(int) + 3
    axes = [lo[i] + step * np.arange(counts[i]) for i in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    sdf = reduce(lambda acc, s: _smooth_min(acc, s.distance(points), blend), shapes[1:], shapes[0].distance(points))
    # Samples at or near the level set put cut points on or next to a grid corner, which makes slivers of
    # near-zero area (fatal to cotangent Laplacians). Keeping every sample a tenth of a cell off the level set
    # keeps cut points that far from corners, and moves the surface by at most a tenth of a cell.
    inside = -sdf.reshape(counts)
    inside = np.where(np.abs(inside) < 0.1 * step, np.copysign(0.1 * step, inside), inside)
    # PyMCubes winds faces counter-clockwise seen from where the volume is negative, i.e. outward here.
    vertices, faces = mcubes.marching_cubes(inside, 0.0)
    return lo + vertices * step, faces.astype(np.int64)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _frame(forward: np.ndarray, up_hint: np.ndarray) -> np.ndarray:
    """[3, 3] orthonormal rows (across, up, forward) with ``forward`` exact and ``up`` as near ``up_hint``."""
    across = _unit(np.cross(up_hint, forward))
    return np.stack([across, np.cross(forward, across), forward])


# ---------------------------------------------------------------------------------------------------------
# Characters. Numbers are for the default body and scale with it; comments give the anatomy they stand for.

def _biped(p: Proportions, pose: str) -> tuple[dict[str, np.ndarray], list]:
    """The mannequin's joints {name: [3]} and the primitives of its body."""
    s = p.height / 1.70              # overall size
    g = p.girth
    hs = p.head / 0.23               # head size
    P = lambda x, y, z: np.array([x, y, z], dtype=float)  # noqa: E731

    chin = p.height - p.head
    shoulder_y = chin - 0.07 * s
    joints = {
        "hips": P(0, p.leg + 0.05 * s, -0.01 * s),            # centre of the pelvis
        "chest": P(0, shoulder_y - 0.05 * s, -0.005 * s),      # upper thorax, between the shoulders
        "neck": P(0, chin - 0.035 * s, -0.015 * s),            # base of the neck
        "head": P(0, p.height - 0.74 * p.head, -0.01 * hs),    # base of the skull
        "head_end": P(0, p.height - 0.004 * s, 0.005 * hs),    # crown, just inside the top of the skull
    }
    joints["spine"] = P(0, 0.5 * (joints["hips"][1] + joints["chest"][1]), -0.012 * s)   # lumbar, at the waist

    trunk_half_width = 0.16 * g * s      # at the hips and the rib cage; the waist is narrower
    shapes = [
        _Ellipsoid(joints["hips"], P(trunk_half_width, 0.14 * s, 0.105 * g * s)),                 # pelvis
        _Ellipsoid(joints["spine"], P(0.14 * g, 0.22, 0.095 * g ** 1.6) * s),                     # waist, belly
        _Ellipsoid(P(0, shoulder_y - 0.11 * s, 0.005 * s), P(trunk_half_width, 0.16 * s, 0.11 * g * s)),  # ribs
        _Cone(P(0, shoulder_y - 0.04 * s, -0.015 * s), joints["head"], 0.058 * s * g ** 0.5, 0.05 * s),  # neck
        _Ellipsoid(P(0, p.height - 0.098 * hs, 0.005 * hs), P(0.077, 0.098, 0.099) * hs),  # cranium
        _Ellipsoid(P(0, p.height - 0.165 * hs, 0.022 * hs), P(0.058, 0.068, 0.075) * hs),  # face and jaw
    ]

    upper, fore, hand = 0.405 * p.arm, 0.34 * p.arm, 0.255 * p.arm
    r_shoulder, r_elbow, r_wrist = 0.05 * s * g, 0.04 * s * g, 0.028 * s * g ** 0.5
    hand_thick, r_tip = 0.02 * s, 0.016 * s
    shoulder_x = p.shoulder_width / 2
    if pose == "down":
        # Hang the arm just far enough from vertical that the elbow clears the widest part of the trunk and the
        # wrist the hips, leaving a gap bigger than the blend so the two surfaces do not fuse.
        trunk = trunk_half_width + 0.03 * s
        sin_drop = max((trunk + r_elbow - shoulder_x) / upper, (trunk + hand_thick - shoulder_x) / (upper + fore),
                       np.sin(np.radians(6.0)))
        arm_dir = P(sin_drop, -np.sqrt(1.0 - sin_drop ** 2), 0)
    else:
        drop = np.radians(_ARM_DROP[pose])
        arm_dir = P(np.cos(drop), -np.sin(drop), 0)
    # Palms face the ground in the T-pose and turn toward the thighs as the arm drops.
    palm_normal = P(-arm_dir[1], arm_dir[0], 0)
    hand_frame = np.stack([palm_normal, np.cross(arm_dir, palm_normal), arm_dir])

    r_thigh, r_knee, r_ankle = 0.075 * s * g, 0.053 * s * g, 0.036 * s * g ** 0.5
    ankle_y = 0.08 * s
    for side, m in (("left", 1.0), ("right", -1.0)):
        shoulder = P(m * shoulder_x, shoulder_y, -0.01 * s)
        d = arm_dir * P(m, 1, 1)
        elbow = shoulder + upper * d
        wrist = elbow + fore * d
        fingertips = wrist + hand * d
        hip = P(m * p.hip_width / 2, p.leg, 0)
        knee = P(m * (p.hip_width / 2 - 0.005 * s), ankle_y + 0.5 * (p.leg - ankle_y), 0.01 * s)
        ankle = P(m * (p.hip_width / 2 - 0.01 * s), ankle_y, 0)   # above the heel
        toe = ankle + P(0, 0.025 * s - ankle_y, 0.135 * s)          # ball of the foot
        joints.update({
            f"{side}_shoulder": shoulder, f"{side}_elbow": elbow, f"{side}_wrist": wrist,
            f"{side}_hand_end": fingertips - 0.004 * s * d,           # middle fingertip, just inside
            f"{side}_hip": hip, f"{side}_knee": knee, f"{side}_ankle": ankle, f"{side}_toe": toe,
            f"{side}_toe_end": toe + P(0, -0.003 * s, 0.066 * s),   # tip of the big toe, just inside
        })
        hand_axes = hand_frame * P(m, 1, 1)[None, :]
        shapes += [
            # Trapezius and deltoid: rounds the shoulder from the base of the neck out over the arm's top.
            _Cone(P(0, shoulder_y + 0.01 * s, -0.015 * s), shoulder, 0.06 * s * g, r_shoulder * 1.05),
            _Cone(shoulder, elbow, r_shoulder, r_elbow),
            _Cone(elbow, wrist, r_elbow, r_wrist),
            # Mitten hand, flat across the palm, with a blunt rounded edge along the fingertips.
            _Ellipsoid(wrist + 0.4 * hand * d, P(hand_thick, 0.045 * s, 0.5 * hand), hand_axes),
            _Cone(fingertips - r_tip * d - 0.025 * s * hand_axes[1], fingertips - r_tip * d + 0.025 * s * hand_axes[1],
                  r_tip, r_tip),
            _Cone(hip, knee, r_thigh, r_knee),
            _Cone(knee, ankle, r_knee, r_ankle),
            # Foot from behind the heel to the ball, sole on the ground; the toes reach past the ball.
            _Ellipsoid(ankle + P(0, 0.035 * s - ankle_y, 0.045 * s), P(0.043, 0.035, 0.115) * s),
            _Ellipsoid(toe + P(0, 0.024 * s - toe[1], 0.015 * s), P(0.042, 0.024, 0.055) * s),
        ]
    return joints, shapes


def _quadruped(p: QuadrupedProportions) -> tuple[dict[str, np.ndarray], list]:
    """The animal's joints {name: [3]} and the primitives of its body."""
    g = p.girth
    S = p.shoulder_height
    half = p.body / 2
    P = lambda x, y, z: np.array([x, y, z], dtype=float)  # noqa: E731

    # The chest hangs down to just above the elbows, so the trunk's height follows the legs and its depth the
    # girth.
    elbow_y = 0.64 * S
    trunk_y = elbow_y + 0.17 * g
    hip_y = trunk_y                         # the hip joints sit level with the middle of the trunk
    paw_r = 0.028 * g ** 0.5
    head_dir = _unit([0, -0.3, 1])

    joints = {
        "hips": P(0, hip_y + 0.05 * g, -half + 0.03),          # centre of the pelvis
        "spine": P(0, trunk_y + 0.06 * g, -0.05 * p.body),     # loins
        "chest": P(0, trunk_y + 0.04 * g, half - 0.25),        # middle of the thorax
        "neck": P(0, trunk_y + 0.09 * g, half + 0.03),         # base of the neck
        "tail_base": P(0, hip_y + 0.07 * g, -half - 0.085),
    }
    joints["head"] = joints["neck"] + P(0, 0.13, 0.12) * (p.head / 0.26) ** 0.5 + P(0, 0.03 * g, 0)  # skull base
    joints["head_end"] = joints["head"] + (p.head - 0.004) * head_dir                              # nose tip
    joints["tail_end"] = joints["tail_base"] + (p.tail - 0.004) * _unit([0, -0.55, -1])

    hs = p.head / 0.26
    nose_r = 0.026 * hs
    tail_r = 0.012 + 0.006 * g
    neck_dir = joints["head"] - joints["neck"]
    shapes = [
        _Ellipsoid(P(0, trunk_y, half - 0.17), P(0.12 * g, 0.15 * g, 0.2 + 0.03 * g)),            # rib cage
        _Ellipsoid(P(0, trunk_y + 0.035 * g, -0.06 * p.body), P(0.095 * g, 0.11 * g, 0.2 * p.body / 0.5)),  # loins
        _Ellipsoid(P(0, hip_y + 0.04 * g, -half + 0.01), P(0.105 * g, 0.125 * g, 0.13)),          # rump
        # Neck from inside the chest, through the neck joint, to the skull.
        _Cone(joints["neck"] - 0.6 * neck_dir, joints["head"], 0.09 * g, 0.06 * hs),
        _Ellipsoid(joints["head"] + 0.3 * p.head * head_dir + P(0, 0.015 * hs, 0), P(0.068, 0.07, 0.09) * hs,
                   _frame(head_dir, P(0, 1, 0))),                                                 # skull
        _Cone(joints["head"] + 0.45 * p.head * head_dir, joints["head"] + (p.head - nose_r) * head_dir,
              0.045 * hs, nose_r),                                                                # muzzle
        _Cone(joints["tail_base"], joints["tail_base"] + (p.tail - tail_r) * _unit([0, -0.55, -1]),
              0.03 * g, tail_r),
    ]

    for side, m in (("left", 1.0), ("right", -1.0)):
        x = m * 0.075 * g
        shoulder = P(x, S, half)                               # point of the shoulder
        elbow = P(x, elbow_y, half - 0.12 * S)
        wrist = P(x, 0.21 * S, half - 0.1 * S)                # carpus
        fpaw = P(x, paw_r, half - 0.1 * S + 0.04)              # middle of the paw pad
        hip = P(x, hip_y, -half)
        knee = P(x, 0.63 * hip_y, -half + 0.18 * hip_y)        # stifle, forward of the hip
        ankle = P(x, 0.33 * hip_y, -half - 0.16 * hip_y)       # hock, behind
        bpaw = P(x, paw_r, -half - 0.16 * hip_y + 0.05)
        joints.update({
            f"front_{side}_shoulder": shoulder, f"front_{side}_elbow": elbow,
            f"front_{side}_wrist": wrist, f"front_{side}_paw": fpaw,
            f"back_{side}_hip": hip, f"back_{side}_knee": knee,
            f"back_{side}_ankle": ankle, f"back_{side}_paw": bpaw,
        })
        r_paw = P(0.034 * g ** 0.5, paw_r, 0.048 * g ** 0.5)
        # The toe tips, just inside the front of each paw's pad, below the paw joint (the feet stand lowest).
        toe = P(0, -0.3 * paw_r, 0.012 + 0.954 * r_paw[2] - 0.003)
        joints.update({f"front_{side}_paw_end": fpaw + toe, f"back_{side}_paw_end": bpaw + toe})
        shapes += [
            # Shoulder blade: fills the trunk's side from the withers down to the point of the shoulder.
            _Cone(shoulder + P(-m * 0.02 * g, 0.1 * g, -0.06), shoulder, 0.05 * g, 0.055 * g),
            _Cone(shoulder, elbow, 0.055 * g, 0.042 * g),
            _Cone(elbow, wrist, 0.042 * g, 0.028 * g),
            _Cone(wrist, fpaw, 0.028 * g, 0.024 * g),
            _Ellipsoid(fpaw + P(0, 0, 0.012), r_paw),
            _Ellipsoid(0.7 * hip + 0.3 * knee, P(0.05 * g, 0.08 * g, 0.1) * hip_y / 0.43),  # haunch muscles
            _Cone(hip, knee, 0.07 * g, 0.045 * g),
            _Cone(knee, ankle, 0.045 * g, 0.026 * g),
            _Cone(ankle, bpaw, 0.026 * g, 0.024 * g),
            _Ellipsoid(bpaw + P(0, 0, 0.012), r_paw),
        ]
    return joints, shapes
