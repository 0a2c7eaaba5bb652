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

Every write is atomic: the data goes to a hidden temporary file (or folder) in the destination directory,
which is then renamed over the destination, so a reader never sees a half-written output and a failed write
leaves the previous output, if any, untouched and no temporary behind. A write that cannot be done raises
:class:`~autorig.errors.OutputError` with one line naming the path and the reason.

Format modules import only ``autorig.result``, ``autorig.errors`` and the helpers in this module.
"""
from __future__ import annotations

import os
import secrets
import shutil
from pathlib import Path

import numpy as np

from ..errors import OutputError
from ..result import Rig

__all__ = ["FORMATS", "write_rig", "check_output", "default_output_path", "check_rig", "write_file_atomic",
           "write_folder_atomic", "decimal_strings"]

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
        _refuse_input(path, Path(input_path))
    if fmt == "pinocchio":
        from .pinocchio import FILES
        _check_folder(path, FILES)
    else:
        _check_file(path)
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


def check_rig(rig: Rig) -> None:
    """Raise ``ValueError`` if ``rig``'s arrays disagree in shape or hold values no format can store.

    A malformed rig is a bug upstream, not something the user can fix, hence not an ``AutorigError``.
    """
    J = len(rig.names)
    parents = np.asarray(rig.parents)
    joints = np.asarray(rig.joints)
    weights = np.asarray(rig.weights)
    vertices = np.asarray(rig.vertices)
    faces = np.asarray(rig.faces)
    if J == 0:
        raise ValueError("rig has no joints")
    if parents.shape != (J,) or joints.shape != (J, 3):
        raise ValueError(f"rig has {J} names but parents {parents.shape} and joints {joints.shape}")
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise ValueError(f"rig vertices have shape {vertices.shape}, expected [V, 3] with V > 0")
    if weights.shape != (len(vertices), J):
        raise ValueError(f"rig weights have shape {weights.shape}, expected {(len(vertices), J)}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise ValueError(f"rig faces have shape {faces.shape}, expected [F, 3] with F > 0")
    if not all(-1 <= int(p) < j for j, p in enumerate(parents)):
        raise ValueError("rig parents must be -1 or the index of an earlier joint")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError("rig faces index vertices that do not exist")
    for name, array in (("joints", joints), ("vertices", vertices), ("weights", weights)):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"rig {name} contain NaN or infinity")
    if weights.size and weights.min() < 0:
        raise ValueError("rig weights must be >= 0")


def write_file_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and ``os.replace``.

    Raises ``OutputError`` (and leaves nothing behind) if ``path`` is a directory, its directory does not
    exist, or the write fails.
    """
    path = Path(path)
    _check_file(path)
    tmp = _temp_name(path)
    try:
        # 0o666 rather than mkstemp's 0o600, so the output gets the permissions the umask gives new files.
        with os.fdopen(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), "wb") as f:
            f.write(data)
            f.flush()
            # The rename below is only all-or-nothing across a crash if the data reached the disk first.
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as e:
        raise OutputError(f"cannot write {path}: {_reason(e)}") from None
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def write_folder_atomic(folder: str | os.PathLike, files: dict[str, bytes]) -> None:
    """Create ``folder`` holding exactly ``files`` ({file name: content}), replacing an earlier output.

    The files are written into a temporary folder beside ``folder`` which is then renamed into place. An
    existing ``folder`` is replaced only if it holds nothing but files of the same names (an earlier output
    of the same kind); any other existing folder, or a file at that path, is refused with ``OutputError``
    rather than deleted, so a mistyped path cannot wipe a user's directory.
    """
    folder = Path(folder)
    _check_folder(folder, files)
    tmp, old = _temp_name(folder), None
    try:
        os.mkdir(tmp, 0o777)
        for name, data in files.items():
            with open(os.path.join(tmp, name), "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
        if folder.exists():
            # A directory cannot be renamed over a non-empty one: move the old output aside first, so the
            # window in which neither exists is two renames long, and put it back if the second fails.
            old = _temp_name(folder)
            os.rename(folder, old)
            try:
                os.rename(tmp, folder)
            except OSError:
                os.rename(old, folder)
                old = None
                raise
        else:
            os.rename(tmp, folder)
    except OSError as e:
        # If putting the old output back failed too, it stays in its hidden folder rather than being lost.
        raise OutputError(f"cannot write {folder}: {_reason(e)}") from None
    finally:
        if os.path.lexists(tmp):
            shutil.rmtree(tmp, ignore_errors=True)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def parents_first(parents: np.ndarray) -> tuple[list[int], np.ndarray]:
    """The joints (parents [J], -1 for a root) reordered so that every parent precedes its children, as close to
    0..J-1 as can be: (order [J], the old index of each joint in the new order; parents [J] in the new order
    and numbering)."""
    order: list[int] = []
    placed = np.zeros(len(parents), dtype=bool)
    for j in range(len(parents)):
        chain = []
        while j >= 0 and not placed[j]:
            chain.append(j)
            placed[j] = True
            j = parents[j]
        order.extend(reversed(chain))
    new_index = np.empty(len(parents), dtype=np.int64)
    new_index[order] = np.arange(len(parents))
    return order, np.array([new_index[parents[j]] if parents[j] >= 0 else -1 for j in order], dtype=np.int64)


def decimal_strings(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` rounded to ``decimals`` decimal places, as text: an object array of the same shape.

    Plain fixed-point, shortest form: ``0.25``, ``1``, ``0.000001``, ``0`` (never ``-0`` or an exponent),
    so a value always prints the same way and the text reads back as the rounded value. Weight tables are
    millions of cells over a few hundred thousand distinct values, so each distinct value is formatted once.
    """
    scaled = np.round(np.asarray(values, dtype=np.float64) * 10 ** decimals).astype(np.int64)
    if scaled.size == 0:
        return np.empty(scaled.shape, dtype=object)
    low, high = int(scaled.min()), int(scaled.max())
    if high - low <= 4 * scaled.size:
        # Weights span a small range of integers: a lookup table finds the distinct ones without sorting.
        present = np.zeros(high - low + 1, dtype=bool)
        present[scaled - low] = True
        distinct = np.flatnonzero(present) + low
        table = np.empty(len(present), dtype=object)
        table[distinct - low] = [_fixed_point(q, decimals) for q in distinct.tolist()]
        return table[scaled - low]
    texts = np.empty(scaled.size, dtype=object)
    texts[:] = [_fixed_point(q, decimals) for q in scaled.ravel().tolist()]
    return texts.reshape(scaled.shape)


def _fixed_point(q: int, decimals: int) -> str:
    """``q / 10**decimals`` written out exactly, without trailing zeros."""
    whole, fraction = divmod(abs(q), 10 ** decimals)
    digits = f"{fraction:0{decimals}d}".rstrip("0")
    return ("-" if q < 0 else "") + str(whole) + ("." + digits if digits else "")


def _refuse_input(output: Path, input_path: Path) -> None:
    """Raise ``OutputError`` if writing ``output`` could overwrite or delete ``input_path``."""
    out = Path(os.path.realpath(output))
    src = Path(os.path.realpath(input_path))
    same = out == src
    if not same and output.exists() and input_path.exists():
        same = os.path.samefile(output, input_path)  # hard links and case-insensitive file systems
    if same or out in src.parents:
        raise OutputError(f"cannot write {output}: it would overwrite the input {input_path}")


def _check_file(path: Path) -> None:
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a directory")
    _check_parent(path)


def _check_folder(folder: Path, names) -> None:
    """Refuse a ``folder`` that exists and is not an earlier output holding only files called ``names``."""
    if folder.exists() or folder.is_symlink():
        if folder.is_symlink() or not folder.is_dir():
            raise OutputError(f"cannot write {folder}: it exists and is not a folder")
        foreign = sorted(p.name for p in folder.iterdir() if p.name not in names or not p.is_file())
        if foreign:
            raise OutputError(f"cannot write {folder}: the folder exists and holds other files "
                              f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''})")
    _check_parent(folder)


def _check_parent(path: Path) -> None:
    parent = path.parent
    if not parent.is_dir():
        what = "does not exist" if not parent.exists() else "is not a directory"
        raise OutputError(f"cannot write {path}: the directory {parent} {what}")


def _temp_name(path: Path) -> str:
    """A fresh hidden name beside ``path``: same directory, so renaming it onto ``path`` is atomic."""
    return os.path.join(path.parent, f".{path.name}.{secrets.token_hex(8)}.tmp")


def _reason(error: OSError) -> str:
    if isinstance(error, PermissionError):
        return "permission denied"
    return error.strerror.lower() if error.strerror else str(error)
