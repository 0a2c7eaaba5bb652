"""Limits against hostile sizes: a mesh file's declared counts are checked against the bytes it holds, and
against ``max_faces`` and the memory this machine has, before anything is allocated for them. A header that
promises 2³¹ vertices, a glTF accessor that runs past its buffer, or a mesh that would need more memory than
there is becomes an ``InputError`` (exit 2, one line), never a ``MemoryError`` or the kernel's OOM killer.

    check_faces(n_faces, max_faces, "hero.ply")       # InputError if over the limit or past the memory
    check_declared(count, 12, len(data) - offset, "element vertex", "hero.ply")
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError

# Default of --max-faces: five times the largest mesh the speed table measures (1M faces, ~1 GB).
MAX_FACES = 5_000_000
# Peak memory per input face of a whole rig: ~0.96 GB at 1M faces (the guide's speed table, docs/speed.md), rounded up.
BYTES_PER_FACE = 1_100
# Peak memory per byte of a mesh file while it is read: the bytes, their text, its lines and the parsed arrays.
BYTES_PER_FILE_BYTE = 6


def check_faces(count: int, max_faces: int | None, name: str) -> None:
    """Refuse a mesh of ``count`` triangles (declared or read) over ``max_faces`` (None: no limit) or too big
    for the memory available."""
    if max_faces is not None and count > max_faces:
        raise InputError(f"{name}: {count:,} faces, more than --max-faces {max_faces:,} (raise it to rig this)")
    check_memory(count * BYTES_PER_FACE, f"{count:,} faces", name)


def check_file_size(path: Path) -> None:
    """Refuse, before reading it, a mesh file too big to read in the memory available."""
    try:
        size = path.stat().st_size
    except OSError:
        return  # the reader reports it
    check_memory(size * BYTES_PER_FILE_BYTE, f"a file of {size / 1e9:.1f} GB", str(path))


def check_declared(count: int, item_bytes: int, present: int, what: str, name: str) -> None:
    """Refuse a declared ``count`` of items of ``item_bytes`` each (at least) that the ``present`` bytes cannot
    hold: a truncated or lying header, caught before an array of that size is made."""
    if count < 0:
        raise InputError(f"{name}: {what}: a negative count ({count})")
    if count * item_bytes > present:
        raise InputError(f"{name}: {what}: {count:,} declared, but the file holds only {present:,} bytes for "
                         f"them (truncated or corrupt)")


def check_memory(needed: int, what: str, name: str) -> None:
    """Refuse work that would need ``needed`` bytes when less memory is available."""
    available = available_memory()
    if available is not None and needed > available:
        raise InputError(f"{name}: {what} would need about {needed / 1e9:.1f} GB of memory, and "
                         f"{available / 1e9:.1f} GB is available")


def available_memory() -> int | None:
    """Bytes this process may still allocate: the system's available memory, or less under a cgroup (a
    container's) limit; None where neither can be read (not Linux)."""
    found = []
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError):
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if limit != "max":
            found.append(max(int(limit) - int(used), 0))
    except (OSError, ValueError):
        pass
    return min(found) if found else None
