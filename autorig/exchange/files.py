"""Atomic writes of output files and folders, and the checks that refuse an output before any work.

Every write is atomic: the data goes to a hidden temporary file (or folder) in the destination directory,
which is then renamed over the destination, so a reader never sees a half-written output and a failed write
leaves the previous output, if any, untouched and no temporary behind. A write that cannot be done raises
:class:`~autorig.errors.OutputError` with one line naming the path and the reason.
"""
from __future__ import annotations

import os
import secrets
import shutil
from pathlib import Path

from ..errors import OutputError


def write_file_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and ``os.replace``.

    Raises ``OutputError`` (and leaves nothing behind) if ``path`` is a directory, its directory does not
    exist, or the write fails.
    """
    path = Path(path)
    check_file(path)
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
    check_folder(folder, files)
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


def refuse_input(output: Path, input_path: Path) -> None:
    """Raise ``OutputError`` if writing ``output`` could overwrite or delete ``input_path``."""
    out = Path(os.path.realpath(output))
    src = Path(os.path.realpath(input_path))
    same = out == src
    if not same and output.exists() and input_path.exists():
        same = os.path.samefile(output, input_path)  # hard links and case-insensitive file systems
    if same or out in src.parents:
        raise OutputError(f"cannot write {output}: it would overwrite the input {input_path}")


def check_file(path: Path) -> None:
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a directory")
    _check_parent(path)


def check_folder(folder: Path, names) -> None:
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
