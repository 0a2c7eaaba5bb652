"""Four-legged animals re-posed through their artists' weights: walking, the head low, both (``animals.py --poses``).

A game's animals are rigged from whatever frame their file holds, and not every file holds the animal standing
square: a walk cycle's first frame has the legs apart, a grazing animal its head down. Each pose turns bones of
the animal's artist's skeleton about its left axis (forward kinematics down the artist's hierarchy, as
``poses.py`` turns a biped's) and skins the mesh with the artist's weights (linear blend skinning); the truth
moves with the skeleton. The poses:

- ``walk``: the front left leg 25 deg forward, the front right 20 deg back, the back left 20 deg back, the back
  right 25 deg forward (a walk's diagonal pairs), each turned at its top joint the artist has (the shoulder or
  hip, else the elbow or knee; a foot the artist's rig holds apart, an IK foot, is carried with its leg);
- ``head low``: the neck turned 40 deg down at its base (as an animal walks or grazes with its head low), or as
  far as it turns before the head goes below the ground (the feet's level): a short-legged animal's snout
  reaches the ground first (0 A.D.'s boar at 20 deg, the pig and the rhino at 26, OpenClonk's puka at 15 and
  mooq at 39; turned the whole 40 the boar's snout went 20 % of its height through the floor, and the lowest
  part of the shape, where the orientation's cues look for the feet, was its snout alone);
- ``walk, head low``: both.

A pose names joints of the template map (``quadruped_map``); an animal whose artist has none of a pose's joints
is skipped for that pose.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from humanoid import AXES
from poses import posed_skeleton, skinned

LEG_TOPS = {"front": ("shoulder", "elbow", "wrist"), "back": ("hip", "knee", "ankle")}
WALK = {"front_left": -25.0, "front_right": 20.0, "back_left": 20.0, "back_right": -25.0}   # + : back
HEAD_LOW = 40.0   # deg, the neck turned down
GROUND = 0.005   # of the height: how far below the feet's level the posed mesh may reach (the ground)
GROUND_STEPS = 10   # halvings of the neck's turn in finding the most the ground allows (40 / 2**10 deg)
POSES = {
    "walk": {"legs": WALK},
    "head low": {"neck": HEAD_LOW},
    "walk, head low": {"legs": WALK, "neck": HEAD_LOW},
}


def rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    """The rotation by ``degrees`` about the unit ``axis`` (right-handed)."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_rotvec(np.radians(degrees) * np.asarray(axis, float)).as_matrix()


def turns(example, pose: str, neck: float | None = None) -> dict[int, np.ndarray] | None:
    """{artist joint index: rotation [3, 3] of its frame, world axes} for ``pose``; None when the artist has no
    joint to turn for a part of it. About the left axis (up x front): +degrees takes the front toward down (a
    head lowered) and down toward the back (a leg swung back)."""
    up, front = (np.array(AXES[axis], float) for axis in (example.up, example.front))
    left = np.cross(up, front)
    out = {}
    spec = POSES[pose]
    for leg, degrees in spec.get("legs", {}).items():
        top = next((example.key_of[f"{leg}_{j}"] for j in LEG_TOPS[leg.split("_")[0]]
                    if f"{leg}_{j}" in example.key_of), None)
        if top is None:
            return None
        out[top] = rotation(left, degrees)
    if "neck" in spec:
        bone = example.key_of.get("neck", example.key_of.get("head"))
        if bone is None:
            return None
        out[bone] = rotation(left, spec["neck"] if neck is None else neck)
    return out


def posed_example(example, pose: str):
    """A copy of ``example`` (``autorig.learn.examples.Example``) in ``pose``, its mesh skinned with its
    artist's weights and its joints moved with the skeleton; None when the pose cannot be made (``turns``). A
    lowered neck turns as far as the ground lets the head go (``GROUND``)."""
    made = _posed(example, pose, None)
    neck = POSES[pose].get("neck")
    if made is None or neck is None:
        return made
    level = _posed(example, pose, 0.0)      # the same pose with the neck not turned: where its feet are
    if not _below_ground(level, made):
        return made
    lo, hi = 0.0, float(neck)
    for _ in range(GROUND_STEPS):
        mid = (lo + hi) / 2
        if _below_ground(level, _posed(example, pose, mid)):
            hi = mid
        else:
            lo = mid
    return _posed(example, pose, lo)


def _posed(example, pose: str, neck: float | None):
    turned = turns(example, pose, neck)
    if turned is None:
        return None
    rest = np.asarray(example.positions, float)
    world, posed = posed_skeleton(_carried(example, turned), rest,
                                  lambda k, inherited: turned[k] @ inherited if k in turned else inherited)
    vertices = skinned(np.asarray(example.vertices, float), example.weights, world, rest, posed)
    return replace(example, name=f"{example.name} ({pose})", vertices=vertices, positions=posed)


def _below_ground(example, posed) -> bool:
    """Whether ``posed``'s mesh reaches below ``example``'s lowest point (its feet) by more than ``GROUND``
    (``example``: the same pose with the neck not turned, so that a leg swung under the body sets the ground)."""
    up = np.array(AXES[example.up], float)
    rest = np.asarray(example.vertices, float) @ up
    return float((np.asarray(posed.vertices, float) @ up).min()) < rest.min() - GROUND * float(np.ptp(rest))


def _carried(example, turned: dict) -> np.ndarray:
    """[J] the artist's parents, with each separate tree that holds a mapped joint of a turned leg hung from
    the leg's turned joint: a game rig's IK feet are roots of their own (Quaternius's), and the foot must go
    where the leg goes."""
    parents = np.array(example.parents, dtype=np.int64)

    def root(k: int) -> int:
        while parents[k] >= 0:
            k = int(parents[k])
        return k
    for leg in WALK:    # every leg
        joints = [example.key_of[f"{leg}_{j}"] for j in LEG_TOPS[leg.split("_")[0]] + ("paw",)
                  if f"{leg}_{j}" in example.key_of]
        top = next((j for j in joints if j in turned), None)
        if top is None:
            continue
        for j in joints:
            r = root(j)
            if r != root(top):
                parents[r] = top
    return parents

