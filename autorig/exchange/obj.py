"""A plain triangle mesh as Wavefront OBJ (``v`` and ``f`` lines only), e.g. a rig's mesh in one pose."""
from __future__ import annotations

import os

import numpy as np

from .files import write_file_atomic

__all__ = ["write_obj", "obj_bytes"]


def write_obj(vertices: np.ndarray, faces: np.ndarray, path: str | os.PathLike) -> None:
    """Write vertices [V, 3] and triangles faces [F, 3] (0-based) to ``path``, atomically."""
    write_file_atomic(path, obj_bytes(vertices, faces))


def obj_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """The OBJ text: vertices in order with 9 significant digits (float32 round-trips), 1-based faces."""
    vertex_lines = "".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in np.asarray(vertices, dtype=np.float64))
    face_lines = "".join(f"f {a} {b} {c}\n" for a, b, c in (np.asarray(faces, dtype=np.int64) + 1).tolist())
    return (vertex_lines + face_lines).encode("ascii")
