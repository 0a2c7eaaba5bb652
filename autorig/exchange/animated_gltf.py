"""An animated rig as glTF 2.0: the skinned file of :mod:`autorig.exchange.gltf` plus one animation.

The animation (named after the motion) has one LINEAR sampler per animated joint, its input the frame times
and its output that joint node's rotation (unit quaternions x, y, z, w, each frame's sign chosen next to the
previous frame's so interpolation takes the short way), and one for the root node's translation. Joints whose
local rotation never changes get no channel and keep their rest transform.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
import pygltflib
from pygltflib import Accessor, Animation, AnimationChannel, AnimationChannelTarget, AnimationSampler, BufferView

from ..result import Rig
from .files import write_file_atomic
from .gltf import _document

if TYPE_CHECKING:  # format modules import no algorithms (see autorig.exchange)
    from ..show.pose import Animation as RigAnimation

__all__ = ["write_animated_glb", "animated_glb_bytes", "quaternions"]


def write_animated_glb(rig: Rig, animation: RigAnimation, path: str | os.PathLike, name: str = "motion") -> None:
    """Write ``rig`` moving as ``animation`` says to the ``.glb`` file ``path``, atomically."""
    write_file_atomic(path, animated_glb_bytes(rig, animation, name))


def animated_glb_bytes(rig: Rig, animation: RigAnimation, name: str = "motion") -> bytes:
    """The ``.glb`` file for ``rig`` with ``animation`` as a glTF animation called ``name``."""
    doc, blob = _document(rig)
    blob = bytearray(blob)

    def add(array: np.ndarray, kind: str, **extra) -> int:
        data = np.ascontiguousarray(array, dtype="<f4").tobytes()
        doc.bufferViews.append(BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        blob.extend(data)
        doc.accessors.append(Accessor(bufferView=len(doc.bufferViews) - 1, componentType=pygltflib.FLOAT,
                                      count=len(array), type=kind, **extra))
        return len(doc.accessors) - 1

    times = np.asarray(animation.times, dtype=np.float32)
    time_accessor = add(times, "SCALAR", min=[float(times.min())], max=[float(times.max())])
    samplers, channels = [], []
    root = int(np.flatnonzero(np.asarray(rig.parents) < 0)[0])
    root_path = np.asarray(animation.positions)[:, root]
    samplers.append(AnimationSampler(input=time_accessor, output=add(root_path, "VEC3"), interpolation="LINEAR"))
    channels.append(AnimationChannel(sampler=0, target=AnimationChannelTarget(node=root, path="translation")))
    rotations = quaternions(np.asarray(animation.local))
    for j in np.flatnonzero(animation.animated):
        samplers.append(AnimationSampler(input=time_accessor, output=add(rotations[:, j], "VEC4"),
                                         interpolation="LINEAR"))
        channels.append(AnimationChannel(sampler=len(samplers) - 1,
                                         target=AnimationChannelTarget(node=int(j), path="rotation")))
    doc.animations = [Animation(name=name, samplers=samplers, channels=channels)]
    doc.buffers[0].byteLength = len(blob)
    doc.set_binary_blob(bytes(blob))
    return b"".join(doc.save_to_bytes())


def quaternions(rotations: np.ndarray) -> np.ndarray:
    """Unit quaternions [N, J, 4] (x, y, z, w) of rotation matrices [N, J, 3, 3], continuous along N."""
    from scipy.spatial.transform import Rotation

    N, J = rotations.shape[:2]
    q = Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_quat().reshape(N, J, 4)
    flips = np.sign(np.einsum("nja,nja->nj", q[1:], q[:-1]))
    flips[flips == 0] = 1.0
    q[1:] *= np.cumprod(flips, axis=0)[..., None]
    return q
