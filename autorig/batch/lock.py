"""One batch at a time per output folder, and what a killed one left behind.

Two batches writing into one output folder would overwrite each other's manifest (each keeps its own copy
in memory) and could remove outputs the other just wrote. ``output_lock`` holds an exclusive ``flock`` on
``OUTPUT_DIR/.autorig-batch.lock`` for the whole run: a second batch refuses at once with one line (exit 4,
``OutputError``). The kernel drops the lock when the process ends however it ends, SIGKILL included, so a
killed batch never leaves a stale lock to clear by hand.

A batch killed mid-write leaves at most hidden temporaries (``.NAME.<16 hex>.tmp``, see
``autorig.exchange.files``) beside its outputs, never a partial output; under the lock, the next run removes
them before it starts.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
from pathlib import Path
from typing import Iterator

from ..errors import OutputError

LOCK_NAME = ".autorig-batch.lock"
_TEMPORARY = re.compile(r"^\..+\.[0-9a-f]{16}\.tmp$")   # autorig.exchange.files._temp_name's


@contextlib.contextmanager
def output_lock(output_dir: Path) -> Iterator[None]:
    """Hold the output folder's lock while the block runs; ``OutputError`` if another batch holds it."""
    path = output_dir / LOCK_NAME
    try:
        if os.path.islink(path):  # planted: replaced, never written through (its target is not ours)
            os.unlink(path)
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
    except OSError as e:
        raise OutputError(f"cannot write {path}: {e.strerror or e}") from None
    try:
        try:
            import fcntl
        except ImportError:  # not on POSIX: no lock, as before
            fcntl = None
        if fcntl is not None:
            try:
                fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.pread(descriptor, 32, 0).decode("ascii", "replace").strip()
                raise OutputError(f"cannot write {output_dir}: another autorig batch is writing into it"
                                  + (f" (process {holder})" if holder.isdigit() else "")
                                  + "; wait for it to end, or choose another output folder") from None
            os.ftruncate(descriptor, 0)
            os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(descriptor)  # releases the flock


def remove_temporaries(output_dir: Path) -> None:
    """Delete the hidden temporaries a killed batch left in ``output_dir`` (call it under ``output_lock``)."""
    for folder, dirs, files in os.walk(output_dir):
        for name in files + dirs:
            if _TEMPORARY.match(name):
                target = os.path.join(folder, name)
                with contextlib.suppress(OSError):
                    if os.path.isdir(target) and not os.path.islink(target):
                        shutil.rmtree(target)
                    else:
                        os.unlink(target)
        dirs[:] = [d for d in dirs if not _TEMPORARY.match(d)]
