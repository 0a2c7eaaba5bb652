"""Limits against hostile sizes: a mesh file's declared counts are checked against the bytes it holds, and
against ``max_faces`` and the memory this machine has, before anything is allocated for them. A header that
promises 2³¹ vertices, a glTF accessor that runs past its buffer, or a mesh that would need more memory than
there is becomes an ``InputError`` (exit 2, one line), never a ``MemoryError`` or the kernel's OOM killer.

    check_faces(n_faces, max_faces, "hero.ply")       # InputError if over the limit or past the memory
    check_declared(count, 12, len(data) - offset, "element vertex", "hero.ply")
"""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from ..errors import InputError, RigFailedError

# Default of --max-faces: five times the largest mesh the speed table measures (1M faces, ~1 GB).
MAX_FACES = 5_000_000
# Peak memory per input face of a whole rig: ~0.96 GB at 1M faces (the guide's speed table, docs/speed.md), rounded up.
BYTES_PER_FACE = 1_100
# Peak memory per byte of a mesh file while it is read: the bytes, their text, its lines and the parsed arrays.
BYTES_PER_FILE_BYTE = 6
# The most bytes read from one file that a mesh names (an MTL, a texture, a glTF buffer or image): larger
# ones are refused as unreadable (left out, or exit 2 for a buffer).
MAX_FILE_BYTES = 512 << 20
# The most joints a --skeleton file may have: skin weights solve once per bone (a 10,000-joint file: 30 s
# and more); production rigs, faces included, have a few hundred.
MAX_JOINTS = 1_000
# Work budgets of the stages a small but pathological shape (a random triangle soup, whose surface fills its
# box) can blow up: the shared characters need at most ~100,000 distance-field points and ~350 medial spheres;
# past four to six times that the shape is not a character's skin, and the rig stops with exit 5 rather than
# take minutes and gigabytes (a 600-triangle soup: 676,000 points, 9,006 spheres, 290 s).
MAX_FIELD_POINTS = 400_000
MAX_SPHERES = 2_000
# Distance and winding-number queries cost in proportion to how many triangles' boxes overlap a point: the sum
# of the triangles' bounding-box areas over the mesh's is 2-7 for the shared characters' working copies, 28-511
# for random soups of 100-2,000 triangles (where one query visits most triangles: 400,000 points take minutes).
MAX_LAYERS = 20.0


def over_budget(what: str, count: int, limit: int) -> RigFailedError:
    """The error of a stage whose work (``count`` of ``what``) passes its budget ``limit``."""
    return RigFailedError(f"could not rig: the shape needs more than {limit:,} {what} ({count:,}); its surface "
                          f"fills its box like a random triangle soup, not the closed skin of a character")


def read_regular(path, limit: int | None = MAX_FILE_BYTES) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them (None: the memory's); a FIFO, a device,
    a socket or a folder is refused before it is opened for reading (it could block for ever or never end),
    and so is a file larger than ``limit``: ``OSError`` (its ``strerror`` says why) like any unreadable file."""
    kind = _kind(os.stat(path).st_mode)
    if kind:
        raise OSError(errno.EINVAL, f"not a regular file ({kind})", str(path))
    # O_NONBLOCK: were it swapped for a FIFO since, opening would not wait for a writer.
    descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(descriptor, "rb") as f:
        info = os.fstat(descriptor)
        kind = _kind(info.st_mode)
        if kind:
            raise OSError(errno.EINVAL, f"not a regular file ({kind})", str(path))
        if limit is not None and info.st_size > limit:
            raise OSError(errno.EFBIG, f"{info.st_size / 2**20:,.0f} MB, more than the {limit >> 20} MB read "
                                       f"from one file", str(path))
        if limit is None:
            check_memory(info.st_size, f"a file of {info.st_size / 1e9:.1f} GB", str(path))
        data = f.read(info.st_size if limit is None else min(info.st_size, limit) + 1)
    if limit is not None and len(data) > limit:
        raise OSError(errno.EFBIG, f"more than the {limit >> 20} MB read from one file", str(path))
    return data


def _kind(mode: int) -> str:
    """What a file that is not a regular one is ("" for a regular file)."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "" if stat.S_ISREG(mode) else "not a file"


def check_layers(vertices, faces) -> None:
    """Refuse, before the distance field, a working mesh whose triangles' boxes overlap more than
    ``MAX_LAYERS`` deep (see above): a soup of large crossing triangles, not a surface."""
    import numpy as np
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    extent = np.maximum(np.maximum(a, b), c) - np.minimum(np.minimum(a, b), c)   # [F, 3], no [F, 3, 3] reductions
    box = vertices.max(axis=0) - vertices.min(axis=0)

    def area(e):
        return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 0] * e[..., 2]

    layers = float(area(extent).sum() / max(area(box), 1e-300))
    if layers > MAX_LAYERS:
        raise RigFailedError(f"could not rig: its triangles' boxes overlap {layers:.0f} deep (a character's "
                             f"skin: under {MAX_LAYERS:.0f}); large crossing triangles, like a random soup, "
                             f"would take minutes to measure")


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
