"""The input's look, read at the edge beside ``autorig.input.mesh``: UVs, vertex colours, normals, materials and
textures, so that the rigged file looks like the input (see ``autorig.result.Look``).

    look = load_look("pig.obj", faces)       # faces: load_mesh's triangles, which the look's must match

- OBJ: ``vt`` (one UV set), ``vn``, vertex colours (``v x y z r g b``), ``usemtl`` and ``o``; the MTL files of
  ``mtllib``, their paths relative to the OBJ, and the maps in them relative to the MTL. MTL becomes glTF's
  metallic-roughness material: ``Kd``/``map_Kd`` base colour, ``d``/``Tr`` alpha, ``Ke``/``map_Ke``
  emission, ``norm``/``map_Bump``/``bump`` normal map, ``Pr``/``map_Pr`` roughness (else from ``Ns`` as
  Blender's importer does), ``Pm`` metallic (else 0); a ``map_Kd`` replaces ``Kd``, as in Blender. ``map_Ka``, ``map_Ks`` and ``map_Ns`` have no glTF
  counterpart and are left out. Images other than PNG and JPEG cannot go in a glTF and are left out; so are
  missing ones (the material keeps its colour).
- glTF/GLB: everything ``autorig.exchange.gltf.read_gltf_scene`` gathers: every UV set, COLOR_0, NORMAL, the
  PBR materials with their textures, samplers and images, the mesh nodes' names and extras, the scene's extras.

An OBJ corner (v/vt/vn) that differs from the first corner of its vertex makes a seam copy of that vertex,
appended after the file's vertices. A mesh with nothing but its shape has no look (None).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..result import Image, Look
from .confine import Dropped
from .limits import read_regular
from .mesh_files import obj_text

__all__ = ["load_look", "matching_look", "material_files"]


def load_look(path: str | Path, faces: np.ndarray, allow_outside: bool = False, data: bytes | None = None
              ) -> Look | None:
    """The look of the mesh file ``path`` whose triangles ``load_mesh`` read as ``faces`` [F, 3], or None.
    ``data``: an OBJ's bytes, when the caller has read them already (``autorig.input.read``: each input file is
    read once).

    Raises ``InputError`` for an unreadable file; a missing, refused (``autorig.input.confine``: outside the mesh's
    folder unless ``allow_outside``) or unusable MTL or texture only leaves that part out, recorded in
    ``Look.dropped``; OBJ texture coordinates or normals that do not parse or point past the file's leave the
    whole look out.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".glb", ".gltf"):
        from ..exchange.gltf import read_gltf_scene
        look = read_gltf_scene(path, allow_outside)[2]
    elif suffix == ".obj":
        try:
            look = _obj_look(path, faces, allow_outside, data)
        except (ValueError, IndexError):
            # Texture coordinates or normals that do not parse or point nowhere: the shape, which load_mesh
            # has checked, still rigs; the look is left out rather than guessed.
            look = None
    else:
        return None
    return matching_look(look, faces)


def matching_look(look: Look | None, faces: np.ndarray) -> Look | None:
    """``look`` if its triangles are the mesh's ``faces`` [F, 3], else None."""
    if look is not None and not np.array_equal(np.asarray(look.vertex_of)[look.faces], faces):
        # Both readers triangulate the same way; if they ever disagree, a bare rig beats a wrong look.
        return None
    return look


# ------------------------------------------------------------------------------------------------------ OBJ

def _obj_look(path: Path, faces: np.ndarray, allow_outside: bool, data: bytes | None) -> Look | None:
    if data is None:
        try:
            data = read_regular(path, None)
        except OSError as e:
            raise InputError(f"{path}: cannot read file ({e.strerror or e})") from None
    # A bare OBJ (most scans) is passed over at the speed of a byte search, with no decoding.
    if not any(_contains(data, key) for key in (b"vt ", b"vn ", b"usemtl", b"mtllib")) and not _has_vertex_colors(data):
        return None
    text = data.decode("latin-1")
    text = obj_text(text)
    lines = text.split("\n")
    if "\n " in text or text.startswith(" "):
        lines = [line.lstrip() for line in lines]
    parsed = _statements_fast(lines)
    if parsed is None or not np.array_equal(parsed[4][:, 0], np.asarray(faces).reshape(-1)):
        parsed = _statements(lines)
    positions, colors, uvs, normals, table, face_material, face_part, material_names, part_names, libraries = parsed
    if not len(table):
        return None
    vertex_of, corner_vertex = _split_seams(table, positions)
    W = len(vertex_of)
    first_corner = np.full(W, -1)
    first_corner[corner_vertex[::-1]] = np.arange(len(table))[::-1]
    has = first_corner >= 0
    texcoords = []
    if len(uvs) and (table[:, 1] >= 0).any():
        uv = np.zeros((W, 2), dtype=np.float32)
        rows = table[first_corner[has], 1]
        values = np.array(uvs, dtype=np.float64)[np.maximum(rows, 0)]
        values[rows < 0] = 0.0
        # OBJ's v grows upwards from the image's bottom, glTF's downwards from its top.
        uv[has] = np.column_stack([values[:, 0], 1.0 - values[:, 1]])
        texcoords.append(uv)
    vertex_normals = None
    if len(normals) and (table[:, 2] >= 0).all():
        vertex_normals = np.zeros((W, 3), dtype=np.float32)
        n = np.array(normals, dtype=np.float64)[table[first_corner[has], 2]]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        vertex_normals[has] = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        vertex_normals[~has] = (0.0, 0.0, 1.0)
    vertex_colors = None
    if colors is not None:
        vertex_colors = np.hstack([np.asarray(colors, dtype=np.float32)[vertex_of], np.ones((W, 1), dtype=np.float32)])
    materials, textures, images, dropped = _read_materials(path, libraries, material_names, allow_outside)
    return Look(vertex_of=vertex_of, faces=corner_vertex.reshape(-1, 3), texcoords=texcoords,
                colors=vertex_colors, normals=vertex_normals,
                face_material=np.asarray(face_material, dtype=np.int64),
                face_part=np.asarray(face_part, dtype=np.int64),
                parts=[{"name": name or path.stem, "extras": {}} for name in part_names],
                materials=materials, textures=textures,
                samplers=[{"wrapS": 10497, "wrapT": 10497}] if textures else [], images=images, dropped=dropped)


def _statements(lines: list[str]):
    """Line-by-line parse of the OBJ statements the look needs (any file ``autorig.input.mesh`` reads):
    (vertex count, colours [V, 3] or None, UVs [T, 2], normals [N, 3], corners [3F, 3] (v, vt, vn) 0-based
    and -1 where absent, face_material [F], face_part [F], material names, part names, MTL libraries)."""
    positions, colors, uvs, normals = 0, [], [], []
    corners: list[tuple[int, int, int]] = []
    face_material, face_part = [], []
    material_names: list[str] = []
    part_names: list[str | None] = [None]
    libraries: list[str] = []
    material, part = -1, 0
    for line in lines:
        parts = line.partition("#")[0].split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            positions += 1
            colors.append([float(c) for c in parts[4:7]] if len(parts) >= 7 else None)
        elif key == "vt":
            uvs.append((float(parts[1]), float(parts[2]) if len(parts) > 2 else 0.0))
        elif key == "vn":
            normals.append((float(parts[1]), float(parts[2]), float(parts[3])))
        elif key == "f":
            polygon = [_corner(c, positions, len(uvs), len(normals)) for c in parts[1:]]
            for k in range(1, len(polygon) - 1):
                corners.extend((polygon[0], polygon[k], polygon[k + 1]))
                face_material.append(material)
                face_part.append(part)
        elif key == "usemtl":
            material = _material_index(material_names, " ".join(parts[1:]))
        elif key == "o":
            # A new object starts a new part, unless the current one has no faces yet (then it is renamed).
            if face_part and face_part[-1] == part:
                part_names.append(None)
                part = len(part_names) - 1
            part_names[part] = " ".join(parts[1:])
        elif key == "mtllib":
            libraries.extend(parts[1:])
    rgb = None
    if any(c is not None for c in colors):
        rgb = np.array([c if c is not None else [1.0, 1.0, 1.0] for c in colors])
    return (positions, rgb, np.array(uvs, dtype=np.float64).reshape(-1, 2),
            np.array(normals, dtype=np.float64).reshape(-1, 3), np.array(corners, dtype=np.int64).reshape(-1, 3),
            face_material, face_part, material_names, part_names, libraries)


def _material_index(names: list[str], name: str) -> int:
    if name not in names:
        names.append(name)
    return names.index(name)


def _statements_fast(lines: list[str]):
    """``_statements`` vectorised for the usual OBJ: numbers only, positive indices, every face corner written
    the same way (v, v/vt, v//vn or v/vt/vn). None for anything else, which ``_statements`` then reads."""
    from .mesh_files import fan

    v, vt, vn, f = [], [], [], []
    events: list[tuple[str, str, int]] = []    # (statement, its argument, polygons before it)
    for line in lines:
        head = line[:2]
        if head == "v ":
            v.append(line[2:])
        elif head == "vt":
            vt.append(line[3:])
        elif head == "vn":
            vn.append(line[3:])
        elif head == "f ":
            f.append(line[2:])
        elif head in ("us", "o ", "mt"):
            key, _, argument = line.partition("#")[0].strip().partition(" ")
            events.append((key, argument.strip(), len(f)))
    faces_text = "\n".join(f)
    if not f or "-" in faces_text or "#" in faces_text or "#" in "".join(v):
        return None
    try:
        counts = np.fromiter(map(len, map(str.split, f)), dtype=np.int64, count=len(f))
        corners = int(counts.sum())
        first = f[0].split()[0]
        slashes, empty_uv = first.count("/"), "//" in first
        # Every corner written like the first; a mix that adds up the same is caught by the caller's check of
        # the vertex indices against autorig.input.mesh's.
        if (counts.min() < 3 or faces_text.count("/") != corners * slashes
                or faces_text.count("//") != (corners if empty_uv else 0)):
            return None
        fields = (faces_text.replace("//", "/0/") if empty_uv else faces_text).replace("/", " ")
        numbers = np.fromstring(fields, dtype=np.int64, sep=" ")
        if numbers.size != corners * (slashes + 1):
            return None
        numbers = numbers.reshape(corners, slashes + 1) - 1
        xyz = _numbers(v, (3, 6))
        uvs = _numbers(vt, (2, 3)) if vt else np.zeros((0, 2))
        normals = _numbers(vn, (3,)) if vn else np.zeros((0, 3))
    except ValueError:
        return None
    if xyz is None or uvs is None or normals is None:
        return None
    uvs = uvs[:, :2]
    table = np.full((corners, 3), -1, dtype=np.int64)
    table[:, :numbers.shape[1]] = numbers
    triangles = fan(np.arange(corners), counts)
    polygon_of = np.repeat(np.arange(len(f)), counts - 2)
    material_names: list[str] = []
    part_names: list[str | None] = [None]
    libraries: list[str] = []
    material_from, material_ids, part_from = [0], [-1], [0]
    for key, argument, before in events:
        if key == "usemtl":
            material_from.append(before)
            material_ids.append(_material_index(material_names, argument))
        elif key == "o":
            if before > part_from[-1]:   # the current part has faces: a new one
                part_names.append(None)
                part_from.append(before)
            part_names[-1] = argument
        elif key == "mtllib":
            libraries.extend(argument.split())
    polygon_material = np.asarray(material_ids)[np.searchsorted(material_from, np.arange(len(f)), "right") - 1]
    polygon_part = np.searchsorted(part_from, np.arange(len(f)), "right") - 1
    return (len(v), xyz[:, 3:6] if xyz.shape[1] == 6 else None, uvs, normals, table[triangles.reshape(-1)],
            polygon_material[polygon_of], polygon_part[polygon_of], material_names, part_names, libraries)


def _numbers(lines: list[str], widths: tuple[int, ...]) -> np.ndarray | None:
    """[len(lines), width] floats of lines that all hold ``width`` numbers, one of ``widths``; else None."""
    values = np.fromstring(" ".join(lines), dtype=np.float64, sep=" ")
    width = len(values) // len(lines) if lines else 0
    if width not in widths or width * len(lines) != len(values):
        return None
    return values.reshape(len(lines), width)


def _contains(data: bytes, word: bytes) -> bool:
    """``word in data`` for a word of two or more bytes, looked for from each place its second byte occurs: that
    is a one-byte scan (memchr) through a bare OBJ, whose numbers hold no letters, where the search for "vt "
    itself stalls on every "v" (1M-face OBJ: the four words 0.145 -> 0.015 s)."""
    i = data.find(word[1:2], 1)
    while i >= 0:
        if data.startswith(word, i - 1):
            return True
        i = data.find(word[1:2], i + 1)
    return False


def _has_vertex_colors(data: bytes) -> bool:
    """Whether the first vertex line has colours (x y z r g b): files give all vertices colours or none."""
    start = data.find(b"v ")
    while start > 0 and data[start - 1:start] not in b"\n\r":
        start = data.find(b"v ", start + 1)
    line = data[start: data.find(b"\n", start)] if start >= 0 else b""
    return len(line.partition(b"#")[0].split()) >= 7


def _corner(spec: str, positions: int, uvs: int, normals: int) -> tuple[int, int, int]:
    """One ``f`` corner ``v``, ``v/vt``, ``v//vn`` or ``v/vt/vn`` as 0-based indices (-1 where absent);
    negative indices count back from the latest element, as ``autorig.input.mesh`` reads them."""
    fields = spec.split("/")
    out = []
    for k, count in enumerate((positions, uvs, normals)):
        text = fields[k] if k < len(fields) else ""
        if not text:
            out.append(-1)
            continue
        index = int(text)
        out.append(index - 1 if index > 0 else count + index)
    return out[0], out[1], out[2]


def _split_seams(table: np.ndarray, positions: int) -> tuple[np.ndarray, np.ndarray]:
    """(vertex_of [W], the output vertex of each corner [3F]) for corners ``table`` [3F, 3] = (v, vt, vn).

    Output vertex v < ``positions`` is file vertex v with its first corner's attributes; each other distinct
    (v, vt, vn) becomes a copy after them, in order of first appearance.
    """
    # One integer per distinct (v, vt, vn): a 1-D unique is some 20 times faster than np.unique(axis=0).
    span = table.max(axis=0) + 2
    codes = ((table[:, 0] + 1) * span[1] + table[:, 1] + 1) * span[2] + table[:, 2] + 1
    _, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
    keys = table[first]
    # Of the distinct corners of a vertex, the one appearing first in the file keeps the vertex's own slot.
    order = np.lexsort((first, keys[:, 0]))
    primary = np.zeros(len(keys), dtype=bool)
    primary[order[np.r_[True, keys[order[1:], 0] != keys[order[:-1], 0]]]] = True
    slot = np.empty(len(keys), dtype=np.int64)
    slot[primary] = keys[primary, 0]
    copies = np.flatnonzero(~primary)
    copies = copies[np.argsort(first[copies], kind="stable")]
    slot[copies] = positions + np.arange(len(copies))
    vertex_of = np.concatenate([np.arange(positions), keys[copies, 0]]).astype(np.int64)
    return vertex_of, slot[inverse]


# ------------------------------------------------------------------------------------------------------ MTL

def material_files(obj_path: Path, allow_outside: bool = False) -> list[tuple[str, list[str]]]:
    """[(an MTL file named by ``mtllib``, relative to the OBJ; the map files it names, relative to it)]: what
    an OBJ's look reads besides the OBJ (``autorig batch`` sends them to its workers). Each library once, read
    under the rules of the rig itself: in the OBJ's folder (``autorig.confine``) unless ``allow_outside``, a
    regular file, at most ``limits.MAX_FILE_BYTES``; one that breaks them is left for the rig to report."""
    from .confine import Refused, inside
    try:
        text = read_regular(obj_path, None).decode("latin-1")
    except OSError:
        return []
    root = Path(obj_path).parent
    found, seen = [], set()
    for line in text.replace("\r", "\n").split("\n"):
        parts = line.partition("#")[0].split()
        if parts[:1] != ["mtllib"]:
            continue
        for library in parts[1:]:
            if library in seen:
                continue
            seen.add(library)
            try:
                mtl = read_regular(inside(root, library, root, allow_outside)).decode("latin-1")
            except (OSError, Refused):
                found.append((library, []))
                continue
            maps = [_map_file(statement[1:]) for statement in (l.partition("#")[0].split()
                                                               for l in mtl.replace("\r", "\n").split("\n"))
                    if statement and (statement[0].lower().startswith("map_")
                                      or statement[0].lower() in ("bump", "norm", "disp", "decal", "refl"))]
            found.append((library, [m.replace("\\", "/") for m in maps if m]))
    return found


_MAP_OPTIONS_WITH_VALUES = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
                            "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1, "-type": 1}


def _read_materials(obj_path: Path, libraries: list[str], names: list[str], allow_outside: bool = False
                    ) -> tuple[list[dict], list[dict], list[Image], list[Dropped]]:
    """glTF materials for ``names`` (in that order) from the MTL files, the textures and images they use, and
    the MTL files and maps left out (missing, refused by ``autorig.input.confine``, not PNG or JPEG)."""
    from .confine import Refused, image_problem, inside

    root = obj_path.parent
    statements: dict[str, dict[str, list[str]]] = {}
    folders: dict[str, Path] = {}
    dropped: list[Dropped] = []
    for library in dict.fromkeys(libraries):  # each once, however often the OBJ names it
        mtl = obj_path.parent / library
        try:
            text = read_regular(inside(root, library, root, allow_outside)).decode("latin-1")
        except Refused as e:
            dropped.append(Dropped("mtllib", library, str(e)))
            continue
        except OSError as e:
            dropped.append(Dropped("mtllib", library, _unreadable(e)))
            continue
        current = None
        for line in text.replace("\r", "\n").split("\n"):
            parts = line.partition("#")[0].split()
            if not parts:
                continue
            if parts[0] == "newmtl":
                current = " ".join(parts[1:])
                statements.setdefault(current, {})
                folders[current] = mtl.parent
            elif current is not None:
                statements[current][parts[0].lower()] = parts[1:]
    materials, textures, images = [], [], []
    image_index: dict[Path, int] = {}

    def texture(statement: list[str], folder: Path, material: str, key: str) -> int | None:
        file = _map_file(statement)
        if file is None:
            return None
        try:
            where = inside(folder, file, root, allow_outside)
        except Refused as e:
            dropped.append(Dropped(f"material {material!r} {key}", file, str(e)))
            return None
        if where not in image_index:
            try:
                data = read_regular(where)
            except OSError as e:
                dropped.append(Dropped(f"material {material!r} {key}", file, _unreadable(e)))
                return None
            from ..exchange.gltf_look import image_mime_type
            mime = image_mime_type(data)
            if not mime:
                dropped.append(Dropped(f"material {material!r} {key}", file, image_problem(data, file)))
                return None
            images.append(Image(data=data, mime_type=mime, name=where.stem))
            textures.append({"source": len(images) - 1, "sampler": 0})
            image_index[where] = len(textures) - 1
        return image_index[where]

    for name in names:
        given, folder = statements.get(name, {}), folders.get(name, obj_path.parent)
        numbers = {k: [float(x) for x in v[:3]] for k, v in given.items()
                   if k in ("kd", "ke", "d", "tr", "ns", "pr", "pm") and _numeric(v)}
        alpha = numbers["d"][0] if "d" in numbers else (1.0 - numbers["tr"][0] if "tr" in numbers else 1.0)
        pbr: dict = {"baseColorFactor": [*(numbers.get("kd", [0.8, 0.8, 0.8]) + [0.8] * 3)[:3], alpha],
                     "metallicFactor": numbers.get("pm", [0.0])[0]}
        if "pr" in numbers:
            pbr["roughnessFactor"] = numbers["pr"][0]
        elif "ns" in numbers:
            pbr["roughnessFactor"] = 1.0 - math.sqrt(min(max(numbers["ns"][0], 0.0), 1000.0) / 1000.0)
        material: dict = {"name": name, "pbrMetallicRoughness": pbr}
        if (base := texture(given.get("map_kd", []), folder, name, "map_Kd")) is not None:
            # The map replaces Kd, as Blender's OBJ importer reads it (its exporter writes Kd 0.8 beside a map).
            pbr["baseColorTexture"] = {"index": base}
            pbr["baseColorFactor"][:3] = [1.0, 1.0, 1.0]
        if (rough := texture(given.get("map_pr", []), folder, name, "map_Pr")) is not None:
            pbr["metallicRoughnessTexture"] = {"index": rough}
        for key in ("norm", "map_bump", "bump"):
            if (normal := texture(given.get(key, []), folder, name, key)) is not None:
                material["normalTexture"] = {"index": normal}
                break
        emission = numbers.get("ke", [0.0, 0.0, 0.0])
        if (glow := texture(given.get("map_ke", []), folder, name, "map_Ke")) is not None:
            material["emissiveTexture"] = {"index": glow}
            emission = emission if any(emission) else [1.0, 1.0, 1.0]
        if any(emission):
            material["emissiveFactor"] = [min(max(e, 0.0), 1.0) for e in (emission + [0.0] * 3)[:3]]
        if alpha < 1.0 or "map_d" in given:
            material["alphaMode"] = "BLEND"
        materials.append(material)
    return materials, textures, images, dropped


def _unreadable(error: OSError) -> str:
    return "missing file" if isinstance(error, FileNotFoundError) else f"cannot read ({error.strerror or error})"


def _numeric(values: list[str]) -> bool:
    """Whether the statement's first three values are finite numbers (a NaN colour has no JSON)."""
    try:
        return bool(values) and all(math.isfinite(float(v)) for v in values[:3])
    except ValueError:
        return False


def _map_file(statement: list[str]) -> str | None:
    """The file name of a ``map_*`` statement's arguments, after its options (``-s 1 1 1``, ``-bm 0.5``)."""
    k = 0
    while k < len(statement) and statement[k].startswith("-") and statement[k] in _MAP_OPTIONS_WITH_VALUES:
        k += 1 + _MAP_OPTIONS_WITH_VALUES[statement[k]]
    return " ".join(statement[k:]) or None
