"""Output formats for a finished :class:`~autorig.result.Rig`: formats only, no algorithms.

    from autorig.exchange import write_rig, default_output_path
    write_rig(rig, default_output_path("hero.obj", "glb"), "glb", input_path="hero.obj")

Formats (``FORMATS``):

- ``glb``       binary glTF 2.0 with a skin (:mod:`autorig.exchange.gltf`)
- ``gltf``      the same as one self-contained ``.gltf`` JSON file (buffer embedded as a data URI)
- ``pinocchio`` a folder holding Pinocchio's ``skeleton.out`` and ``attachment.out``
                (:mod:`autorig.exchange.pinocchio`)
- ``json``      skeleton, sparse weights, info and timings (:mod:`autorig.exchange.json_format`)
- ``usda``, ``usdc``, ``usdz``  UsdSkel through usd-core (:mod:`autorig.exchange.usd`, extra ``autorig[usd]``)
- ``fbx``       FBX through Blender's exporter (:mod:`autorig.exchange.fbx`; Blender on PATH or $AUTORIG_BLENDER)

Every write is atomic (:mod:`autorig.exchange.files`): a reader never sees a half-written output, and a
write that cannot be done raises :class:`~autorig.errors.OutputError` with one line naming the path and the
reason.

This module is the formats' table and nothing else: it picks the format's module. Format modules import only
``autorig.result``, ``autorig.errors``, the atomic writes (``files``) and the array helpers (``arrays``),
never this module, so that no format imports the table that imports it.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import OutputError
from ..result import Rig
from .arrays import check_rig, decimal_strings, parents_first
from .files import check_file, check_folder, refuse_input, write_file_atomic, write_folder_atomic

__all__ = ["FORMATS", "write_rig", "check_output", "default_output_path", "check_rig", "write_file_atomic",
           "write_folder_atomic", "decimal_strings", "parents_first"]

FORMATS = ("glb", "gltf", "pinocchio", "json", "usda", "usdc", "usdz", "fbx")

_SUFFIXES = {"glb": ".rigged.glb", "gltf": ".rigged.gltf", "pinocchio": ".rigged", "json": ".rigged.json",
             "usda": ".rigged.usda", "usdc": ".rigged.usdc", "usdz": ".rigged.usdz", "fbx": ".rigged.fbx"}


def write_rig(rig: Rig, path: str | os.PathLike, fmt: str, *, input_path: str | os.PathLike | None = None
              ) -> Path:
    """Write ``rig`` to ``path`` in format ``fmt`` (one of ``FORMATS``) and return the path written.

    ``input_path``, when given, is the mesh the rig was made from: the output may neither be that file nor,
    for a Pinocchio folder, contain it, so a mistyped ``-o`` can never destroy the input.
    """
    check_output(path, fmt, input_path=input_path)
    path = Path(path)
    if fmt == "glb":
        from .gltf import write_glb
        write_glb(rig, path)
    elif fmt == "gltf":
        from .gltf import write_gltf
        write_gltf(rig, path)
    elif fmt == "pinocchio":
        from .pinocchio import write_pinocchio
        write_pinocchio(rig, path)
    elif fmt in ("usda", "usdc", "usdz"):
        from .usd import write_usd
        write_usd(rig, path, fmt)
    elif fmt == "fbx":
        from .fbx import write_fbx
        write_fbx(rig, path)
    else:
        from .json_format import write_json
        write_json(rig, path)
    return path


def check_output(path: str | os.PathLike, fmt: str, *, input_path: str | os.PathLike | None = None) -> None:
    """Raise ``OutputError`` now if ``write_rig(rig, path, fmt, input_path=input_path)`` would refuse ``path``.

    Needs no rig, so a caller can check before the slow work (``write_rig`` checks again). It catches an
    unknown format, the input itself (or a folder holding it), a missing directory, a directory where a file
    should go, and an existing path a Pinocchio folder may not replace; a write can still fail later (disk
    full, permission denied).
    """
    if fmt not in FORMATS:
        raise OutputError(f"unknown output format {fmt!r}: choose one of {', '.join(FORMATS)}")
    path = Path(path)
    if input_path is not None:
        refuse_input(path, Path(input_path))
    if fmt == "pinocchio":
        from .pinocchio import FILES
        check_folder(path, FILES)
    else:
        check_file(path)
    if fmt in ("usda", "usdc", "usdz"):
        from .usd import require_usd
        require_usd()
    elif fmt == "fbx":
        from .fbx import blender_path
        blender_path()


def default_output_path(input_path: str | os.PathLike, fmt: str) -> Path:
    """Where ``fmt`` output goes when no path is given: beside the input, named after its stem.

    ``hero.obj`` -> ``hero.rigged.glb`` / ``hero.rigged.gltf`` / ``hero.rigged/`` (pinocchio) /
    ``hero.rigged.json``.
    """
    if fmt not in FORMATS:
        raise OutputError(f"unknown output format {fmt!r}: choose one of {', '.join(FORMATS)}")
    input_path = Path(input_path)
    return input_path.with_name(input_path.stem + _SUFFIXES[fmt])


