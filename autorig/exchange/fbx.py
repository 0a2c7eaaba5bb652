"""FBX output through Blender, the only maintained free FBX writer: autorig writes its ``.glb`` (with the look),
Blender imports it and exports it again with its own FBX exporter (armature, vertex groups and the textures
embedded in the file).

Blender is the ``blender`` on PATH, or the program named by ``$AUTORIG_BLENDER``. Without it the write stops
with one line saying what to install. The script Blender runs is :mod:`autorig.exchange.blender_fbx`.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import OutputError
from ..result import Rig
from .files import write_file_atomic

__all__ = ["write_fbx", "blender_path", "blender_command"]

BLENDER_ENV = "AUTORIG_BLENDER"
SCRIPT = Path(__file__).with_name("blender_fbx.py")
# Blender starts in 1-2 s; a big mesh takes longer to import and export, never this long.
TIMEOUT = 600


def blender_path() -> str:
    """The Blender program to run: ``$AUTORIG_BLENDER`` if set, else ``blender`` on PATH; ``OutputError``
    saying what to install when there is none."""
    named = os.environ.get(BLENDER_ENV)
    if named:
        found = shutil.which(named)
        if found is None:
            raise OutputError(f"FBX output: ${BLENDER_ENV} is {named!r}, which is not a program")
        return found
    found = shutil.which("blender")
    if found is None:
        raise OutputError(f"FBX output needs Blender: install it (apt-get install blender, or blender.org) or "
                          f"set ${BLENDER_ENV} to its program")
    return found


def blender_command(blender: str, script: Path, *args) -> tuple[list[str], dict[str, str]]:
    """(command, environment) to run ``script`` in headless Blender with ``args`` after ``--``.

    Debian's Blender embeds the system Python and finds its home through the first python3 on PATH: the one
    beside the blender program goes first, not a virtual environment's, which lacks Blender's numpy.
    """
    command = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script), "--",
               *map(str, args)]
    env = dict(os.environ, PATH=os.pathsep.join([os.path.dirname(os.path.realpath(blender)),
                                                 os.environ.get("PATH", "")]))
    return command, env


def write_fbx(rig: Rig, path: str | os.PathLike) -> None:
    """Write ``rig`` as FBX to ``path``, atomically, through Blender; ``OutputError`` on failure."""
    from .gltf import write_glb

    path = Path(path)
    blender = blender_path()
    with tempfile.TemporaryDirectory(prefix="autorig-fbx-") as scratch:
        source, target = Path(scratch, "rig.glb"), Path(scratch, "rig.fbx")
        write_glb(rig, source)
        command, env = blender_command(blender, SCRIPT, source, target)
        try:
            run = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT, env=env)
        except (OSError, subprocess.TimeoutExpired) as e:
            raise OutputError(f"cannot write {path}: Blender did not run ({e})") from None
        if run.returncode != 0 or not target.is_file():
            last = next((line for line in reversed((run.stderr + run.stdout).splitlines()) if line.strip()), "")
            raise OutputError(f"cannot write {path}: Blender's FBX export failed ({last.strip()[:200]})")
        write_file_atomic(path, target.read_bytes())
