"""Procedural characters with fingers, for tests of the hands stage (``autorig.hands``).

``fingered_mannequin`` is the README's mannequin (``autorig.samples``) with its mitten hands replaced by a palm,
four fingers and an opposed thumb of three phalanges each, built like the rest of it (a smooth union of tapered
capsules and ellipsoids, marching cubes). Fingers need a finer grid than the body; the signed distance is only
evaluated near each primitive, so the fine grid stays cheap, and the surface is then simplified to about
``faces`` triangles. The finger joints returned are the ones the phalanges were built between.
"""
from __future__ import annotations

from functools import lru_cache

import fast_simplification
import mcubes
import numpy as np

from autorig.samples import Proportions, _biped, _Cone, _Ellipsoid, _lookup, _smooth_min

FINGERS = ("thumb", "index", "middle", "ring", "pinky")


def _hand(wrist, d, across, down, size):
    """Primitives of a hand and its finger joints {finger: [4, 3]} (joints 1, 2, 3, tip).

    wrist [3]; d [3] unit along the forearm; across [3] unit towards the thumb side; down [3] unit out of the
    palm; size: the hand's length (wrist to middle fingertip)."""
    s = size / 0.19
    shapes = [_Ellipsoid(wrist + 0.05 * s * d, np.array([0.045, 0.014, 0.05]) * s,
                         np.stack([across, down, d]))]
    joints = {}
    offsets = {"index": 0.03, "middle": 0.01, "ring": -0.01, "pinky": -0.029}
    lengths = {"index": (0.043, 0.025, 0.02), "middle": (0.047, 0.028, 0.021), "ring": (0.044, 0.027, 0.02),
               "pinky": (0.035, 0.02, 0.018)}
    for finger, z in offsets.items():
        knuckle = wrist + 0.09 * s * d + z * s * across
        direction = d + 0.15 * z / 0.03 * across
        direction /= np.linalg.norm(direction)
        chain = [knuckle]
        for length in lengths[finger]:
            chain.append(chain[-1] + length * s * direction)
        joints[finger] = np.array(chain)
    thumb_dir = 0.55 * d + 0.75 * across + 0.35 * down
    thumb_dir /= np.linalg.norm(thumb_dir)
    base = wrist + 0.015 * s * d + 0.02 * s * across + 0.006 * s * down
    chain = [base]
    for length in (0.04, 0.032, 0.026):
        chain.append(chain[-1] + length * s * thumb_dir)
    joints["thumb"] = np.array(chain)
    for finger, chain in joints.items():
        radius = (0.0095 if finger == "thumb" else 0.0075) * s
        for k in range(3):
            shapes.append(_Cone(chain[k], chain[k + 1], radius * (1 - 0.08 * k), radius * (1 - 0.08 * (k + 1))))
    return shapes, joints


def _mesh_sparse(shapes, step):
    """Marching cubes of the smooth union of ``shapes`` [(primitive, blend)] on a grid of cell ``step``, each
    primitive's distance evaluated only within its bounds (plus its blend): vertices [V, 3], faces [F, 3]."""
    lo = np.min([s.bounds()[0] for s, _ in shapes], axis=0) - 3 * step
    hi = np.max([s.bounds()[1] for s, _ in shapes], axis=0) + 3 * step
    counts = np.ceil((hi - lo) / step).astype(int) + 1
    sdf = np.full(counts, 1.0, dtype=np.float32)
    for shape, blend in shapes:
        a, b = shape.bounds()
        i0 = np.maximum(np.floor((a - blend - lo) / step).astype(int), 0)
        i1 = np.minimum(np.ceil((b + blend - lo) / step).astype(int) + 1, counts)
        axes = [lo[k] + step * np.arange(i0[k], i1[k]) for k in range(3)]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        block = sdf[i0[0]:i1[0], i0[1]:i1[1], i0[2]:i1[2]]
        sdf[i0[0]:i1[0], i0[1]:i1[1], i0[2]:i1[2]] = _smooth_min(
            block.reshape(-1), shape.distance(points), blend).reshape(block.shape)
    inside = -sdf
    inside = np.where(np.abs(inside) < 0.1 * step, np.copysign(0.1 * step, inside), inside)
    vertices, faces = mcubes.marching_cubes(inside, 0.0)
    return lo + vertices * step, faces.astype(np.int64)


@lru_cache(maxsize=4)
def fingered_mannequin(pose: str = "t", faces: int = 30_000):
    """(vertices [V, 3], faces [F, 3], joints {name: [3]} with the finger joints as ``{side}_{finger}1..3`` and
    ``{side}_{finger}_end``) of the mannequin with fingers, about ``faces`` triangles."""
    joints, shapes = _biped(_lookup({"adult": Proportions()}, "adult"), pose)
    kept = []
    for shape in shapes:
        centre = shape.centre if isinstance(shape, _Ellipsoid) else shape.b
        near_hand = [side for side in ("left", "right")
                     if np.linalg.norm(centre - joints[f"{side}_hand_end"]) < 0.6 * np.linalg.norm(
                         joints[f"{side}_hand_end"] - joints[f"{side}_wrist"]) + 1e-9
                     or (isinstance(shape, _Ellipsoid) and np.linalg.norm(centre - joints[f"{side}_wrist"]) < 0.12)]
        if not near_hand:
            kept.append((shape, 0.012))
    for side, m in (("left", 1.0), ("right", -1.0)):
        wrist = joints[f"{side}_wrist"]
        d = joints[f"{side}_wrist"] - joints[f"{side}_elbow"]
        d /= np.linalg.norm(d)
        down = np.cross(d, np.array([0.0, 0.0, 1.0])) * m       # out of the palm: the palm faces the ground in T
        down /= np.linalg.norm(down)
        across = np.cross(down, d) * m                           # towards the thumb: the front (+z) in T
        hand, fingers = _hand(wrist, d, across, down, 0.19)
        kept += [(shape, 0.003) for shape in hand]
        for finger, chain in fingers.items():
            for k in range(3):
                joints[f"{side}_{finger}{k + 1}"] = chain[k]
            joints[f"{side}_{finger}_end"] = chain[3]
    V, F = _mesh_sparse(kept, 0.005)
    V, F = fast_simplification.simplify(V, F.astype(np.int32), target_count=faces)
    return np.asarray(V, np.float64), np.asarray(F, np.int64), joints
