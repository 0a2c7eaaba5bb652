"""Which files an asset may name: only those in its own folder and below it.

A mesh names other files: an OBJ its MTL libraries and their texture maps, a glTF its buffers and images. The
asset folders autorig reads are often filled by others (store downloads, studios, uploads), and whatever it
reads goes into the rig it hands back, so a ``map_Kd /home/me/.ssh/id_rsa.png`` or ``../../secret.png`` would
copy a file from outside the asset into its output. Unless the user allows it (``--allow-outside-paths``), a
name is refused when it is absolute, is a ``file:`` URI, leaves the folder by ``..``, or reaches a file outside
it through a symlink. What is refused, and any texture left out for another reason, is said: one line each
(``Dropped``, ``dropped_line``), printed by the command line and kept in the rig's ``info`` and the batch report.

    path = inside(folder, "textures/skin.png", root)    # raises Refused("...") when the name is not allowed
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlparse

ALLOW_HINT = "--allow-outside-paths to allow"

# "C:/x", "C:\x" and "\\server\share" are absolute on Windows; a file written there names them so.
_WINDOWS_ABSOLUTE = re.compile(r"^([A-Za-z]:[\\/]|[\\/]{2})")
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


class Refused(ValueError):
    """A file name the asset may not use, and why (``str(error)``)."""


@dataclass(frozen=True)
class Dropped:
    """A part of the look left out: what named it (``material 'skin' map_Kd``, ``image 0 'albedo'``), the
    path as the file wrote it, and why."""
    what: str
    path: str
    reason: str

    def as_dict(self) -> dict:
        """What a rig's ``info["dropped"]`` holds, and the batch report (``dropped_line`` reads it)."""
        return {"what": self.what, "path": self.path, "reason": self.reason}


def dropped_line(source: str, dropped: dict) -> str:
    """The warning line of a ``Dropped.as_dict()``, naming ``source``, the mesh file."""
    return f"{source}: {dropped['what']}: {dropped['path']}: {dropped['reason']}; left out"


def inside(folder: str | os.PathLike, name: str, root: str | os.PathLike, allow_outside: bool = False) -> Path:
    """The real path of the file ``name`` as written in a file in ``folder``, relative to it; raises ``Refused``
    unless it lies in ``root`` or below it (or ``allow_outside``). Backslashes count as separators, as in
    files written on Windows."""
    name = name.replace("\\", "/")
    if os.path.isabs(name) or _WINDOWS_ABSOLUTE.match(name):
        if not allow_outside:
            raise Refused(f"an absolute path, outside the asset's folder ({ALLOW_HINT})")
        return Path(os.path.realpath(name))
    target = os.path.join(os.path.abspath(folder), name)
    real = Path(os.path.realpath(target))
    if allow_outside:
        return real
    top = os.path.abspath(root)
    if not _within(os.path.normpath(target), top):
        raise Refused(f"'..' leads outside the asset's folder ({ALLOW_HINT})")
    if not _within(str(real), os.path.realpath(top)):
        raise Refused(f"a symlink leads outside the asset's folder ({ALLOW_HINT})")
    return real


def uri_file(uri: str, folder: str | os.PathLike, root: str | os.PathLike, allow_outside: bool = False) -> Path:
    """The file a glTF ``uri`` (not a ``data:`` one) names, relative to ``folder``, as ``inside`` allows it:
    percent-escapes decoded, a ``file:`` URI only with ``allow_outside``, other schemes (http:, ...) never."""
    if uri.lower().startswith("file:"):
        if not allow_outside:
            raise Refused(f"a file: URI, outside the asset's folder ({ALLOW_HINT})")
        # Here, not at the top: urllib.request imports http.client and ssl (~10 ms of every rig's start).
        from urllib.request import url2pathname
        return Path(os.path.realpath(url2pathname(urlparse(uri).path)))
    if _SCHEME.match(uri) and not _WINDOWS_ABSOLUTE.match(uri):
        raise Refused(f"a {uri.split(':', 1)[0]}: URI; autorig reads only files")
    return inside(folder, unquote(uri), root, allow_outside)


def _within(path: str, top: str) -> bool:
    return path == top or path.startswith(top.rstrip(os.sep) + os.sep)


# Signatures of image files that a glTF cannot hold (it takes PNG and JPEG; WebP and KTX2 by extensions that
# autorig keeps when a glTF input uses them), so that a texture left out says "unsupported" and not "not an
# image".
_OTHER_IMAGES = ((b"BM", "BMP"), (b"GIF8", "GIF"), (b"II*\0", "TIFF"), (b"MM\0*", "TIFF"), (b"DDS ", "DDS"),
                 (b"8BPS", "PSD"), (b"\x76\x2f\x31\x01", "OpenEXR"), (b"#?RADIANCE", "HDR"), (b"#?RGBE", "HDR"),
                 (b"\xabKTX 11", "KTX"), (b"\0\0\0\x0cjP  ", "JPEG 2000"))
_TGA_SUFFIXES = (".tga", ".targa")


def image_problem(data: bytes, name: str, extensions: bool = False) -> str:
    """Why the bytes ``data`` of the file ``name`` cannot be a glTF texture as they are ("" if they can); with
    ``extensions`` (a glTF input's images) WebP and KTX2 can, as the input's extensions say how to read them."""
    if data[:8] == b"\x89PNG\r\n\x1a\n" or data[:3] == b"\xff\xd8\xff":
        return ""
    webp = data[:4] == b"RIFF" and data[8:12] == b"WEBP"
    if extensions and (webp or data[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"):
        return ""
    kind = next((label for signature, label in _OTHER_IMAGES if data.startswith(signature)), None)
    if kind is None and webp:
        kind = "WebP"
    if kind is None and Path(name).suffix.lower() in _TGA_SUFFIXES:
        kind = "TGA"  # TGA has no signature at its start
    if kind is not None:
        return f"unsupported image format ({kind}; a glTF holds PNG and JPEG)"
    return "not an image (neither PNG nor JPEG)"
