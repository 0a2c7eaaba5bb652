"""One reader for an input file: its mesh and its look together, the file read and parsed once.

    vertices, faces, look = read_input("hero.glb")     # look: a ``Look``, or None

``autorig.input.mesh.load_mesh`` reads the mesh alone and ``autorig.input.look.load_look`` the look alone (each
reads the file); the pipeline reads both here, so a glTF is parsed once (its JSON, buffers and scene), and an
OBJ's bytes are read from disk once (the look's statements are then only scanned for when the file has any).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..result import Look
from .limits import MAX_FACES, check_faces, check_file_size
from .look import load_look, matching_look
from .mesh import check_mesh, check_mesh_path, load_mesh, parse_mesh_bytes, read_file

__all__ = ["read_input"]


def read_input(path: str | Path, max_faces: int | None = MAX_FACES, allow_outside: bool = False
               ) -> tuple[np.ndarray, np.ndarray, Look | None]:
    """``(vertices, faces, look)`` of the mesh file ``path``: what ``load_mesh(path, max_faces, allow_outside)``
    and ``load_look(path, faces, allow_outside)`` return, with the same checks and errors (``InputError``, one
    line naming the file), from one reading of the file."""
    path = check_mesh_path(path)
    suffix = path.suffix.lower()
    if suffix in (".glb", ".gltf"):
        from ..exchange.gltf import read_gltf_scene
        check_file_size(path)
        vertices, faces, look = read_gltf_scene(path, allow_outside, max_faces, look=True)
        check_faces(len(faces), max_faces, str(path))
        vertices, faces = check_mesh(vertices, faces, name=str(path))
        return vertices, faces, matching_look(look, faces)
    if suffix == ".obj":
        check_file_size(path)
        data = read_file(path)
        vertices, faces = parse_mesh_bytes(data, path, max_faces)
        check_faces(len(faces), max_faces, str(path))
        vertices, faces = check_mesh(vertices, faces, name=str(path))
        return vertices, faces, load_look(path, faces, allow_outside, data)
    # OFF, PLY and STL carry no look.
    return (*load_mesh(path, max_faces, allow_outside), None)
