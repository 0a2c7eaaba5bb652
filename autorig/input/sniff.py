"""What kind of file a path holds, read from its first bytes (not its name), so that a command given the wrong
kind of file can say what it is: ``autorig pose`` given a mesh as its rig, or a mesh or a glTF as its motion.

``file_kind(path)`` returns a short name ("an OBJ mesh", "a glTF file", "a BVH motion", ...) or None when the
bytes say nothing known; it never raises (an unreadable file is the reader's to report).
"""
from __future__ import annotations

import os

MESH_KINDS = ("an OBJ mesh", "a PLY mesh", "an OFF mesh", "an STL mesh")
OBJ_WORDS = {"v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "mtllib", "usemtl"}


def file_kind(path: str | os.PathLike) -> str | None:
    """The kind of file at ``path`` by its first bytes, or None when unknown or unreadable."""
    try:
        if not os.path.isfile(path):  # a FIFO would block here, a device never end
            return None
        with open(path, "rb") as f:
            head = f.read(4096)
            f.seek(0, os.SEEK_END)
            size = f.tell()
    except OSError:
        return None
    if head.startswith(b"glTF"):
        return "a glTF file"
    if head.startswith(b"Kaydara FBX Binary") or head.lstrip().startswith(b"; FBX"):
        return "an FBX file"
    if head.startswith(b"PXR-USDC") or head.startswith(b"#usda"):
        return "a USD file"
    if head.startswith(b"PK\x03\x04"):
        return "a zip archive"
    if head.startswith(b"\x89PNG") or head.startswith(b"\xff\xd8\xff"):
        return "an image"
    if len(head) >= 84 and size == 84 + 50 * int.from_bytes(head[80:84], "little"):
        return "an STL mesh"
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff")
    first = text.lstrip().split(None, 1)[0] if text.strip() else ""
    if first == "HIERARCHY":
        return "a BVH motion"
    if first == "ply":
        return "a PLY mesh"
    if first in ("OFF", "NOFF", "COFF", "STOFF"):
        return "an OFF mesh"
    if first == "solid":
        return "an STL mesh"
    if first.startswith("{"):
        return "a glTF file" if '"asset"' in text else "a JSON file"
    lines = text.splitlines()[:-1] if len(head) == 4096 else text.splitlines()   # the last may be cut short
    words = {line.split(None, 1)[0] for line in lines if line.strip() and not line.lstrip().startswith("#")}
    if words & {"v", "f"} and words <= OBJ_WORDS:
        return "an OBJ mesh"
    return None
