"""Reading mesh files: OBJ and OFF parsed here (fast, keeping the file's vertices and order), PLY and STL through
trimesh. ``autorig.input.mesh.load_mesh`` picks the reader and checks what it returns; glTF is
``autorig.exchange.gltf``'s.

Every problem with the file raises ``InputError`` with one line naming the file and the problem.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from .limits import check_declared, check_faces

FORMATS = {".obj": "OBJ", ".off": "OFF", ".ply": "PLY", ".stl": "STL", ".glb": "glTF", ".gltf": "glTF"}


def as_text(data: bytes, path: Path, fmt: str) -> str:
    # Text formats never contain NUL bytes; images, archives and binary meshes almost always do.
    if b"\0" in data[:65536]:
        raise InputError(f"{path}: binary data, not a text {fmt} file")
    # latin-1 maps every byte, so odd encodings in comments or names never stop us reading the numbers.
    return data.decode("latin-1")


def _bad_line(path: Path, lineno: int, problem: str) -> InputError:
    return InputError(f"{path}: line {lineno}: {problem}")


_OBJ_KEYWORDS = {"v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "mg", "usemtl", "mtllib"}


def parse_obj(text: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Parse OBJ ``v`` and ``f`` statements ourselves: trimesh's OBJ reader splits vertices at UV seams, drops
    vertices past the last referenced one when there are texture coordinates, splits the file into one geometry
    per material (each with its own copy of the vertices), and resolves negative (relative) indices against the
    end of the file instead of the current position."""
    text = obj_text(text)
    if "\n " in text or text.startswith(" "):
        text = "\n".join([line.lstrip() for line in text.split("\n")])
    fast = _parse_obj_fast(text)
    return fast if fast is not None else _parse_obj_lines(text.split("\n"), path)


def obj_text(text: str) -> str:
    """OBJ text as both OBJ readers split it: CR LF and lone CR line ends made LF, a backslash before a line end
    joining the two lines, tabs made spaces (replaced in that order). The two-character replacements run only
    when their first character occurs at all: a scan for one character costs a tenth of one for two (a 1M-face
    OBJ: 0.09 -> 0.01 s)."""
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    if "\\" in text:
        text = text.replace("\\\n", " ")
    return text.replace("\t", " ")


def _parse_obj_fast(text: str) -> tuple[np.ndarray, np.ndarray] | None:
    """Vectorised parse of the usual OBJ (lines split at "\\n", none starting with a space): numeric 'v' lines
    and 'f' lines with positive indices.

    Returns None when anything is unusual (no faces, relative indices, a malformed line); the line-by-line
    parser then handles the file and reports problems with their line numbers.
    """
    (v_count, v_text), (f_count, faces_text) = _statements(text, ("v ", "f "))
    if not v_count or not f_count:
        return None
    if "#" in faces_text:
        return None
    if "/" in faces_text:
        faces_text = re.sub(r"/\S*", "", faces_text)  # keep the vertex index of each v/vt/vn corner
    face_lines = faces_text.split("\n")
    try:
        vertices = np.loadtxt(v_text.split("\n"), usecols=(0, 1, 2), ndmin=2, comments="#")
        try:  # every face with the same number of corners: one C-speed pass
            table = np.loadtxt(face_lines, dtype=np.int64, ndmin=2)
            index, counts = table.reshape(-1), np.full(len(table), table.shape[1])
        except ValueError:
            corners = [line.split() for line in face_lines]
            counts = np.fromiter(map(len, corners), dtype=np.int64, count=len(corners))
            index = np.array([c for face in corners for c in face], dtype=np.int64)
    except ValueError:
        return None
    if len(vertices) != v_count:    # a "v" line loadtxt skipped as blank: the line parser names it
        return None
    if counts.min() < 3 or index.min() < 1:
        return None
    if counts.max() > max(len(vertices), 1000):  # the line parser names the line
        return None
    if counts.max() == 3:   # triangles only: the fan is the table itself (0.1-0.3 s of gathers saved at 1M faces)
        return vertices, index.reshape(-1, 3) - 1
    return vertices, fan(index - 1, counts)


def _statements(text: str, keywords: tuple[str, ...]) -> list[tuple[int, str]]:
    """For each two-character keyword ("v ", "f "): (how many lines of ``text`` start with it, the rest of those
    lines joined by newlines), as [line[2:] for line in text.split("\\n") if line[:2] == keyword] would give.

    The line starts are found by numpy in the text's bytes and the statements cut out run by run (a file lists
    its vertices, and its faces, in a few long runs): a 1M-face OBJ in 0.45 s instead of 0.65 s of list
    comprehensions over 1.5M lines. Each character is one byte in latin-1 (the text was decoded so), and one
    "?" for any other character, so the offsets agree."""
    data = np.frombuffer(text.encode("latin-1", errors="replace") + b"\n\0\0", dtype=np.uint8)
    starts = np.r_[0, np.flatnonzero(data[:-2] == 10) + 1]        # [L + 1] each line's start, then a sentinel
    lines = starts[:-1]
    out = []
    for keyword in keywords:
        a, b = keyword.encode("latin-1")
        found = np.flatnonzero((data[lines] == a) & (data[lines + 1] == b))   # [K] line numbers, ascending
        if len(found) == 0:
            out.append((0, ""))
            continue
        cut = np.flatnonzero(np.diff(found) != 1)
        first, last = np.r_[found[0], found[cut + 1]], np.r_[found[cut], found[-1]]     # each run's lines
        runs = "\n".join([text[s:e] for s, e in zip(starts[first].tolist(), (starts[last + 1] - 1).tolist())])
        out.append((len(found), runs[2:].replace("\n" + keyword, "\n")))
    return out


def fan(index: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons: ``index`` [sum(counts)] is the polygons' corners one after another, ``counts``
    [P] the corners of each. Returns [sum(counts - 2), 3]: polygon (a, b, c, d) -> (a, b, c), (a, c, d)."""
    triangles = counts - 2
    first = np.repeat(np.cumsum(counts) - counts, triangles)  # [T] the polygon's first corner
    k = np.arange(len(first)) - np.repeat(np.cumsum(triangles) - triangles, triangles)  # [T] 0, 1, .. per polygon
    return np.stack([index[first], index[first + k + 1], index[first + k + 2]], axis=1)


def _parse_obj_lines(lines: list[str], path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Line-by-line OBJ parse: slower, but handles relative indices and names the line of any problem."""
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    recognised = content = False
    for lineno, line in enumerate(lines, 1):
        parts = line.partition("#")[0].split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            try:
                vertices.append((float(parts[1]), float(parts[2]), float(parts[3])))
            except (IndexError, ValueError):
                raise _bad_line(path, lineno, f"a vertex needs three numbers, got {line.strip()[:60]!r}") from None
        elif key == "f":
            try:
                corners = [int(c.split("/", 1)[0]) for c in parts[1:]]
            except ValueError:
                raise _bad_line(path, lineno, f"malformed face {line.strip()[:60]!r}") from None
            if len(corners) < 3:
                raise _bad_line(path, lineno, f"a face needs at least three vertices, got {len(corners)}")
            if len(corners) > max(len(vertices), 1000):  # a million corners among a few hundred vertices: noise
                raise _bad_line(path, lineno, f"a face of {len(corners):,} corners, more than the "
                                              f"{len(vertices):,} vertices before it")
            if 0 in corners:
                raise _bad_line(path, lineno, "vertex index 0 (OBJ indices start at 1)")
            # Negative indices count back from the most recent vertex; an index still negative after this
            # points before the first vertex, and check_mesh reports it as out of range.
            n = len(vertices)
            corners = [c - 1 if c > 0 else n + c for c in corners]
            faces.extend((corners[0], corners[k], corners[k + 1]) for k in range(1, len(corners) - 1))
        content = True
        recognised = recognised or key in _OBJ_KEYWORDS
    if content and not recognised:
        raise InputError(f"{path}: not an OBJ file (no OBJ statements such as 'v' or 'f' found)")
    return (np.array(vertices, dtype=np.float64).reshape(-1, 3),
            np.array(faces, dtype=np.int64).reshape(-1, 3))


def parse_off(text: str, path: Path, max_faces: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Parse OFF (and its COFF/NOFF/STOFF variants, whose extra per-vertex columns we ignore) ourselves:
    trimesh's OFF reader fails on files that mix triangles with other polygons."""
    lines = [(n, l.split("#", 1)[0].split()) for n, l in enumerate(text.splitlines(), 1)]
    lines = [(n, tokens) for n, tokens in lines if tokens]
    if not lines:
        raise InputError(f"{path}: empty file (no vertices)")
    keyword = lines[0][1][0]
    if not keyword.upper().endswith("OFF"):
        raise InputError(f"{path}: not an OFF file (it must start with 'OFF')")
    if not re.fullmatch(r"(ST)?C?N?OFF", keyword.upper()):
        raise InputError(f"{path}: {keyword} files are not supported (only 3D OFF, COFF, NOFF, STOFF)")
    # The counts may share the keyword's line ("OFF 8 6 12") or follow it.
    if len(lines[0][1]) > 1:
        (counts_line, counts), body = (lines[0][0], lines[0][1][1:]), lines[1:]
    else:
        (counts_line, counts), body = (lines[1] if len(lines) > 1 else (1, [])), lines[2:]
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        raise _bad_line(path, counts_line, "expected the vertex and face counts") from None
    if n_vertices < 0 or n_faces < 0 or len(body) < n_vertices + n_faces:
        raise InputError(f"{path}: truncated: the header promises {n_vertices} vertices and {n_faces} faces "
                         f"but the file has only {len(body)} data lines")
    check_faces(n_faces, max_faces, str(path))
    vertices = []
    for n, tokens in body[:n_vertices]:
        try:
            vertices.append((float(tokens[0]), float(tokens[1]), float(tokens[2])))
        except (IndexError, ValueError):
            raise _bad_line(path, n, "a vertex needs three numbers") from None
    faces = []
    for n, tokens in body[n_vertices:n_vertices + n_faces]:
        try:
            k = int(tokens[0])
            corners = [int(c) for c in tokens[1:1 + k]]
        except ValueError:
            raise _bad_line(path, n, "malformed face") from None
        if k < 3 or len(corners) < k:
            raise _bad_line(path, n, "a face needs a vertex count of at least 3 and that many indices")
        if k > max(n_vertices, 1000):  # a million corners among a few hundred vertices: a million triangles of noise
            raise _bad_line(path, n, f"a face of {k:,} corners, more than the file's {n_vertices:,} vertices")
        faces.extend((corners[0], corners[i], corners[i + 1]) for i in range(1, k - 1))
    return (np.array(vertices, dtype=np.float64).reshape(-1, 3),
            np.array(faces, dtype=np.int64).reshape(-1, 3))


# Bytes of each PLY property type, and the least an ASCII value takes ("0" and a separator).
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
_ASCII_VALUE = 2


def check_header(path: Path, suffix: str, max_faces: int | None) -> None:
    """Check a PLY's or binary STL's declared counts against its bytes and ``max_faces`` before trimesh reads
    it: trimesh allocates what the header says (a PLY that promises 2³¹ vertices, 2 GB or a MemoryError)."""
    try:
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError as e:
        raise InputError(f"{path}: cannot read file ({e.strerror or e})") from None
    if suffix == ".stl" and len(head) >= 84 and not head.lstrip()[:5].lower() == b"solid":
        count = int.from_bytes(head[80:84], "little")
        check_declared(count, 50, size - 84, "triangles", str(path))
        check_faces(count, max_faces, str(path))
    elif suffix == ".ply" and head.startswith(b"ply"):
        end = head.find(b"end_header")
        if end < 0:
            return  # trimesh says what is wrong with it
        binary = b"format binary" in head[:end]
        body = size - head.find(b"\n", end) - 1
        elements: list[list] = []   # [name, count, least bytes of one]
        for line in head[:end].decode("latin-1").splitlines():
            words = line.split()
            if words[:1] == ["element"] and len(words) >= 3:
                try:
                    elements.append([words[1], int(words[2]), 0])
                except ValueError:
                    return
            elif words[:1] == ["property"] and elements:
                # a list property takes at least its count (an empty list)
                kind = words[2] if words[1:2] == ["list"] and len(words) > 2 else words[1] if len(words) > 1 else ""
                elements[-1][2] += _PLY_SIZES.get(kind, 1) if binary else _ASCII_VALUE
        least = 0
        for name, count, each in elements:
            check_declared(count, max(each, 1), body - least, f"element {name}", str(path))
            least += count * max(each, 1)
            if name == "face":
                check_faces(count, max_faces, str(path))


def load_with_trimesh(path: Path, suffix: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    fmt = FORMATS[suffix]
    try:
        # process=False keeps the file's vertices as they are (no merging, no reordering); materials would
        # only cost time (and decode images) for data we never use.
        scene = trimesh.load_scene(str(path), file_type=suffix[1:], process=False, skip_materials=True)
    except Exception as e:  # trimesh's readers raise anything from KeyError to struct.error on bad data
        message = " ".join(str(e).split())[:150] or type(e).__name__
        raise InputError(f"{path}: cannot read as {fmt} ({message})") from None
    vertex_blocks, face_blocks, offset, points_only = [], [], 0, False
    for node in sorted(scene.graph.nodes_geometry):
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry[geometry_name]
        if not isinstance(geometry, trimesh.Trimesh):
            points_only = points_only or isinstance(geometry, trimesh.PointCloud)
            continue
        vertices = np.asarray(geometry.vertices, dtype=np.float64)
        vertices = vertices @ transform[:3, :3].T + transform[:3, 3]
        vertex_blocks.append(vertices)
        face_blocks.append(np.asarray(geometry.faces, dtype=np.int64).reshape(-1, 3) + offset)
        offset += len(vertices)
    if not vertex_blocks and points_only:
        raise InputError(f"{path}: a point cloud (no faces); autorig needs a surface mesh")
    if not vertex_blocks:
        raise InputError(f"{path}: no mesh found (empty, or not a valid {fmt} file)")
    return np.concatenate(vertex_blocks), np.concatenate(face_blocks)
