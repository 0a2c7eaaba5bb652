"""Shared inputs for the preview, pose and Blender tests: a rigged mannequin and small BVH motions.

``rigged_mannequin()`` rigs the adult T-pose mannequin with the biped template once per test session (a few
seconds); callers must not modify what it returns. ``mannequin_bvh()`` writes a BVH of the mannequin's own
skeleton under CMU joint names, so a test knows exactly what retargeting should do.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

# Biped template joint -> CMU (cgspeed) BVH joint, as autorig.show.pose.BIPED_MAP resolves it for CMU files.
CMU_NAMES = {"hips": "Hips", "spine": "Spine", "chest": "Spine1", "neck": "Neck", "head": "Head"}
for _side in ("left", "right"):
    _S = _side.capitalize()
    CMU_NAMES.update({f"{_side}_shoulder": f"{_S}Arm", f"{_side}_elbow": f"{_S}ForeArm",
                      f"{_side}_wrist": f"{_S}Hand", f"{_side}_hip": f"{_S}UpLeg", f"{_side}_knee": f"{_S}Leg",
                      f"{_side}_ankle": f"{_S}Foot", f"{_side}_toe": f"{_S}ToeBase"})


@lru_cache(maxsize=None)
def mannequin_sample():
    """The adult T-pose mannequin (autorig.samples.Sample)."""
    from autorig.samples import mannequin

    return mannequin()


@lru_cache(maxsize=None)
def rigged_mannequin():
    """(sample, rig): the adult T-pose mannequin and its rig by the hand-set biped, whose joints sit where the
    mannequin's own skeleton has them (the built-in biped follows the corpus artists' conventions), so that a
    motion made on the true skeleton (``mannequin_bvh``) fits the rig."""
    from pathlib import Path

    import autorig

    sample = mannequin_sample()
    handset = Path(__file__).resolve().parents[1] / "templates" / "handset" / "biped.json"
    return sample, autorig.rig((sample.vertices, sample.faces), handset)


def mannequin_bvh(poses: list[dict[str, tuple[float, float, float]]], root_moves: list[tuple[float, float, float]],
                  frame_time: float = 1 / 24, units: float = 100.0) -> str:
    """BVH text for the mannequin's true skeleton (tips as End Sites) in ``units`` per metre, +y up, facing +z.

    poses       one {template joint: (x, y, z) degrees} per frame; unnamed joints stay at rest
    root_moves  the root's displacement from its rest position in each frame, in metres
    The root's channels are "Xposition Yposition Zposition Zrotation Xrotation Yrotation", the other joints'
    "Zrotation Xrotation Yrotation": R = Rz @ Rx @ Ry.
    """
    from autorig.template import load_template

    template = load_template("biped")
    return skeleton_bvh(list(template.names), CMU_NAMES, template.parents, mannequin_sample().joints, poses,
                        root_moves, frame_time, units)


def skeleton_bvh(names: list[str], bvh_names: dict[str, str], parents, joints: dict[str, np.ndarray],
                 poses: list[dict[str, tuple[float, float, float]]], root_moves: list[tuple[float, float, float]],
                 frame_time: float = 1 / 24, units: float = 100.0) -> str:
    """BVH text for a skeleton: ``names`` [J] with ``parents`` [J] (parents first) at ``joints`` {name: [3]}
    (metres), each written as ``bvh_names[name]``; joints ending in ``_end`` are their parent's End Site.
    poses and root_moves as in ``mannequin_bvh``, keyed by ``names``."""
    lines = ["HIERARCHY"]
    order: list[int] = []

    def write(j: int, depth: int) -> None:
        pad = "  " * depth
        offset = (joints[names[j]] - (joints[names[parents[j]]] if parents[j] >= 0 else 0)) * units
        children = [c for c in range(len(names)) if parents[c] == j]
        lines.append(f"{pad}{'ROOT' if parents[j] < 0 else 'JOINT'} {bvh_names[names[j]]}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        lines.append(pad + "  CHANNELS " + ("6 Xposition Yposition Zposition " if parents[j] < 0 else "3 ")
                     + "Zrotation Xrotation Yrotation")
        order.append(j)
        for c in children:
            if names[c].endswith("_end"):
                tip = (joints[names[c]] - joints[names[j]]) * units
                lines.extend([f"{pad}  End Site", pad + "  {",
                              f"{pad}    OFFSET {tip[0]:.6f} {tip[1]:.6f} {tip[2]:.6f}", pad + "  }"])
            else:
                write(c, depth + 1)
        lines.append(pad + "}")

    write(int(np.flatnonzero(np.asarray(parents) < 0)[0]), 0)
    lines += ["MOTION", f"Frames: {len(poses)}", f"Frame Time: {frame_time:.8f}"]
    for pose, move in zip(poses, root_moves):
        values = []
        for j in order:
            if parents[j] < 0:
                values += list((joints[names[j]] + np.asarray(move)) * units)
            x, y, z = pose.get(names[j], (0.0, 0.0, 0.0))
            values += [z, x, y]
        lines.append(" ".join(f"{v:.6f}" for v in values))
    return "\n".join(lines) + "\n"
