"""The look of a mesh in glTF 2.0: read UVs, vertex colours, normals, materials, textures and images from a
glTF's primitives, and write a :class:`~autorig.result.Look` into a document that :mod:`autorig.exchange.gltf`
is building.

Reading gathers every triangle primitive of the given mesh nodes into one vertex list: primitives that share
their vertex accessors (in the same node, when node transforms apply) share their vertices. Images are taken as
the file holds them (the bytes of their buffer view, data URI or file), never decoded.

Writing puts all output vertices in one set of accessors and gives every part (an input mesh) a mesh node of its
own, with one primitive per material its triangles use; the images go into the binary buffer unchanged.
"""
from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pygltflib
from pygltflib import GLTF2, Image as GltfImage, Material, Mesh, Node, Primitive, Sampler, Texture

from ..input.confine import Dropped, Refused, image_problem, uri_file
from ..input.limits import read_regular
from ..result import Image, Look
from .gltf_parts import check_attributes, data_uri_bytes

__all__ = ["Gathered", "gather_primitives", "look_of", "write_look", "image_mime_type"]


@dataclass
class Gathered:
    """The triangle primitives of some mesh nodes as one mesh.

    vertices       [V, 3] float64 (node transforms applied if asked)
    faces          [F, 3] int64
    weights        [V, J] float64 summed skin weights, or None when not asked (J = 0)
    texcoords      list of [V, 2] float32, one per TEXCOORD_n set any primitive has (zeros where one lacks it)
    colors         [V, 4] float32 COLOR_0 (white where a primitive lacks it), or None if none has it
    normals        [V, 3] float32 NORMAL if every primitive has it, else None
    face_material  [F] int64 each triangle's material, -1 for none
    face_part      [F] int64 which of the mesh nodes each triangle comes from
    """
    vertices: np.ndarray
    faces: np.ndarray
    weights: np.ndarray | None
    texcoords: list[np.ndarray]
    colors: np.ndarray | None
    normals: np.ndarray | None
    face_material: np.ndarray
    face_part: np.ndarray


def gather_primitives(doc: GLTF2, buffers: list[bytes], mesh_nodes: list[int], transforms: np.ndarray | None,
                      J: int, read_accessor) -> Gathered:
    """All triangle primitives of the nodes ``mesh_nodes`` (indices into ``doc.nodes``), as one mesh.

    transforms  [len(mesh_nodes), 4, 4] each node's world matrix to apply, or None to keep the vertices as
                stored (a skinned mesh's bind space)
    J           skin joints whose JOINTS_n/WEIGHTS_n to sum into dense weights, 0 for none
    read_accessor  ``(doc, buffers, index) -> [count, width] array`` (``autorig.exchange.gltf``)
    Raises ``ValueError`` when there is no triangle or indices point past their primitive's vertices.
    """
    blocks: list[dict] = []
    faces, materials, parts = [], [], []
    first_vertex: dict[tuple, int] = {}
    count = 0
    for part, node_index in enumerate(mesh_nodes):
        node = doc.nodes[node_index]
        for primitive in doc.meshes[node.mesh].primitives:
            if primitive.mode not in (None, pygltflib.TRIANGLES):
                continue
            attributes = {k: v for k, v in vars(primitive.attributes).items() if v is not None}
            if "POSITION" not in attributes:
                continue
            check_attributes(doc, attributes, primitive.indices)
            key = ((part if transforms is not None else None),) + tuple(sorted(attributes.items()))
            if key not in first_vertex:
                first_vertex[key] = count
                block = _read_block(doc, buffers, attributes, J, read_accessor)
                if transforms is not None:
                    _move(block, transforms[part])
                blocks.append(block)
                count += len(block["POSITION"])
            n = doc.accessors[attributes["POSITION"]].count
            if primitive.indices is None:
                corners = np.arange(n - n % 3)
            else:
                corners = read_accessor(doc, buffers, primitive.indices).ravel()
            if corners.size and (corners.min() < 0 or corners.max() >= n):
                raise ValueError("a primitive's indices point past its vertices")
            triangles = corners[: corners.size - corners.size % 3].reshape(-1, 3) + first_vertex[key]
            faces.append(triangles)
            materials.append(np.full(len(triangles), -1 if primitive.material is None else primitive.material))
            parts.append(np.full(len(triangles), part))
    if not blocks or not sum(map(len, faces)):
        raise ValueError("no triangles")
    sets = max((k for block in blocks for k in block["TEXCOORD"]), default=-1) + 1
    texcoords = [np.concatenate([block["TEXCOORD"].get(k, np.zeros((len(block["POSITION"]), 2)))
                                 for block in blocks]).astype(np.float32) for k in range(sets)]
    colors = None
    if any("COLOR_0" in block for block in blocks):
        colors = np.concatenate([block.get("COLOR_0", np.ones((len(block["POSITION"]), 4)))
                                 for block in blocks]).astype(np.float32)
    normals = None
    if all("NORMAL" in block for block in blocks):
        normals = np.concatenate([block["NORMAL"] for block in blocks]).astype(np.float32)
    return Gathered(vertices=np.concatenate([block["POSITION"] for block in blocks]),
                    faces=np.concatenate(faces).astype(np.int64),
                    weights=np.concatenate([block["weights"] for block in blocks]) if J else None,
                    texcoords=texcoords, colors=colors, normals=normals,
                    face_material=np.concatenate(materials).astype(np.int64),
                    face_part=np.concatenate(parts).astype(np.int64))


def _read_block(doc: GLTF2, buffers: list[bytes], attributes: dict, J: int, read_accessor) -> dict:
    position = read_accessor(doc, buffers, attributes["POSITION"])
    block = {"POSITION": position, "TEXCOORD": {}}
    if "NORMAL" in attributes:
        block["NORMAL"] = read_accessor(doc, buffers, attributes["NORMAL"])
    for name, index in attributes.items():
        if name.startswith("TEXCOORD_"):
            block["TEXCOORD"][int(name[9:])] = read_accessor(doc, buffers, index)
    if "COLOR_0" in attributes:
        color = read_accessor(doc, buffers, attributes["COLOR_0"])
        block["COLOR_0"] = np.hstack([color, np.ones((len(color), 4 - color.shape[1]))])
    if J:
        dense = np.zeros((len(position), J))
        for name in (k for k in attributes if k.startswith("JOINTS_")):
            slots = read_accessor(doc, buffers, attributes[name])
            amounts = read_accessor(doc, buffers, attributes["WEIGHTS_" + name[7:]])
            rows = np.repeat(np.arange(len(position)), slots.shape[1])
            np.add.at(dense, (rows, slots.ravel()), amounts.ravel())
        block["weights"] = dense
    return block


def _move(block: dict, matrix: np.ndarray) -> None:
    """Put a block's positions and normals through a node's world ``matrix`` [4, 4]."""
    block["POSITION"] = block["POSITION"] @ matrix[:3, :3].T + matrix[:3, 3]
    if "NORMAL" in block:
        # Normals go through the inverse transpose, so a scaled node keeps them perpendicular to its faces.
        normals = block["NORMAL"] @ np.linalg.inv(matrix[:3, :3])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        block["NORMAL"] = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def look_of(doc: GLTF2, buffers: list[bytes], gathered: Gathered, mesh_nodes: list[int], path: Path,
            keep_extras: bool = True, allow_outside: bool = False) -> Look:
    """The :class:`Look` of ``gathered`` (from ``gather_primitives`` over ``mesh_nodes``) and ``doc``'s
    materials, textures, samplers and images (read from ``path``'s folder when they are files, confined to it
    unless ``allow_outside``: ``autorig.input.confine``). An image that cannot be had or is not an image is left out
    with the textures that show it (the materials keep their colours), and recorded in ``Look.dropped``."""
    document = json.loads(doc.to_json())
    images, kept, dropped = [], [], []
    read: dict = {}  # one file named by 300 images is read once, and its bytes shared (written once)
    for i, source in enumerate(doc.images or []):
        what = f"image {i}" + (f" {source.name!r}" if source.name else "")
        written = (source.uri if isinstance(source.uri, str) else f"buffer view {source.bufferView}"
                   if source.uri is None else "(a uri that is not a string)")
        try:
            key = (source.uri, source.bufferView) if isinstance(source.uri, (str, type(None))) else None
            if key is None:
                raise ValueError("its uri is not a string")
            if key not in read:
                read[key] = _image_bytes(doc, buffers, source, path, allow_outside)
            data = read[key]
            problem = image_problem(data, written if source.uri else "", extensions=True)
        except Refused as e:
            problem = str(e)
        except OSError as e:
            problem = "missing file" if isinstance(e, FileNotFoundError) else f"cannot read ({e.strerror or e})"
        except (ValueError, IndexError, TypeError, AttributeError) as e:
            problem = f"cannot read ({' '.join(str(e).split())[:100] or type(e).__name__})"
        if problem:
            dropped.append(Dropped(what, written if len(written) <= 200 else written[:60] + "...", problem))
            continue
        images.append(Image(data=data, mime_type=source.mimeType or image_mime_type(data), name=source.name or ""))
        kept.append(i)
    if dropped:
        _keep_images(document, kept)
    parts = []
    for i in mesh_nodes:
        node = doc.nodes[i]
        parts.append({"name": node.name or doc.meshes[node.mesh].name or f"mesh_{i}",
                      "extras": node.extras if isinstance(node.extras, dict) else {}})
    W = len(gathered.vertices)
    scene = (doc.scenes or [None])[doc.scene or 0] if doc.scenes else None
    extras = scene.extras if keep_extras and scene is not None and isinstance(scene.extras, dict) else {}
    return Look(vertex_of=np.arange(W), faces=gathered.faces, texcoords=gathered.texcoords,
                colors=gathered.colors, normals=gathered.normals, face_material=gathered.face_material,
                face_part=gathered.face_part, parts=parts, materials=document.get("materials", []),
                textures=document.get("textures", []), samplers=document.get("samplers", []), images=images,
                extras={k: v for k, v in extras.items() if not k.startswith("autorig_")}, dropped=dropped)


def _keep_images(document: dict, kept: list[int]) -> None:
    """Renumber ``document``'s textures for the images ``kept`` (old indices, in order): textures showing
    another image go (a ``source`` in a texture's extensions counts too), and so do the materials' references
    to them."""
    image_of = {old: new for new, old in enumerate(kept)}
    texture_of, textures = {}, []
    for t, texture in enumerate(document.get("textures") or []):
        holders = [texture] + [e for e in (texture.get("extensions") or {}).values() if isinstance(e, dict)]
        sources = [h["source"] for h in holders if "source" in h]
        if not all(isinstance(source, int) and source in image_of for source in sources):
            continue
        for holder in holders:
            if "source" in holder:
                holder["source"] = image_of[holder["source"]]
        texture_of[t] = len(textures)
        textures.append(texture)
    document["textures"] = textures
    document["materials"] = [_renumbered(m, texture_of) for m in document.get("materials") or []]


def _renumbered(item, texture_of: dict[int, int]):
    """A material's JSON with its texture references (``baseColorTexture``, ``normalTexture``, ...) pointing at
    the renumbered textures, and those to textures that went removed."""
    if isinstance(item, list):
        return [_renumbered(v, texture_of) for v in item]
    if not isinstance(item, dict):
        return item
    renumbered = {}
    for key, value in item.items():
        if key.endswith("Texture") and isinstance(value, dict) and "index" in value:
            index = value["index"]
            if not isinstance(index, int) or index not in texture_of:
                continue
            value = {**value, "index": texture_of[index]}
        renumbered[key] = _renumbered(value, texture_of)
    return renumbered


def _image_bytes(doc: GLTF2, buffers: list[bytes], image: GltfImage, path: Path, allow_outside: bool) -> bytes:
    if image.bufferView is not None:
        view = doc.bufferViews[image.bufferView]
        start = view.byteOffset or 0
        return bytes(buffers[view.buffer][start:start + view.byteLength])
    if image.uri is None:
        raise ValueError("an image has neither a bufferView nor a uri")
    if image.uri.startswith("data:"):
        return data_uri_bytes(image.uri)
    return read_regular(uri_file(image.uri, path.parent, path.parent, allow_outside))


def image_mime_type(data: bytes) -> str:
    """The glTF mime type of an image file's bytes: PNG and JPEG by their signatures, else ""."""
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return "image/png"
    if data[:3] == b"\xff\xd8\xff":
        return "image/jpeg"
    return ""


def write_look(doc: GLTF2, look: Look, add, add_bytes, attributes: dict, skin: int) -> list[int]:
    """Add ``look``'s meshes, materials, textures, samplers and images to ``doc``; returns the new mesh nodes.

    add        ``(array, component, type, target) -> accessor index`` that appends to the binary buffer
    add_bytes  ``(bytes) -> buffer view index`` for the images
    attributes the vertex attributes every primitive shares (POSITION, NORMAL, JOINTS_0, WEIGHTS_0, ...):
               TEXCOORD_n and COLOR_0 are added here
    """
    for k, uv in enumerate(look.texcoords):
        attributes[f"TEXCOORD_{k}"] = add(np.asarray(uv, dtype=np.float32), pygltflib.FLOAT, "VEC2",
                                          pygltflib.ARRAY_BUFFER)
    if look.colors is not None:
        attributes["COLOR_0"] = add(np.asarray(look.colors, dtype=np.float32), pygltflib.FLOAT, "VEC4",
                                    pygltflib.ARRAY_BUFFER)
    views: dict[bytes, int] = {}  # the same bytes, once: one buffer view for every image holding them
    doc.images = [GltfImage(bufferView=views.setdefault(image.data, add_bytes(image.data)) if image.data not in views
                            else views[image.data], mimeType=image.mime_type or None,
                            name=image.name or None) for image in look.images] or None
    doc.samplers = [Sampler.from_dict(s) for s in look.samplers] or None
    doc.textures = [Texture.from_dict(t) for t in look.textures] or None
    doc.materials = [Material.from_dict(m) for m in look.materials] or None
    used = sorted(_extension_names([look.materials, look.textures, look.samplers]))
    if used:
        doc.extensionsUsed = used
    faces = np.asarray(look.faces, dtype=np.uint32)
    nodes = []
    for p, part in enumerate(look.parts):
        primitives = []
        in_part = look.face_part == p
        materials = np.unique(look.face_material[in_part])
        for m in sorted(materials, key=lambda m: (m < 0, m)):
            chosen = faces[in_part & (look.face_material == m)]
            indices = add(chosen.reshape(-1), pygltflib.UNSIGNED_INT, "SCALAR", pygltflib.ELEMENT_ARRAY_BUFFER)
            primitives.append(Primitive(attributes=pygltflib.Attributes(**attributes), indices=indices,
                                        material=int(m) if m >= 0 else None, mode=pygltflib.TRIANGLES))
        if not primitives:
            continue
        doc.meshes.append(Mesh(name=part["name"], primitives=primitives))
        doc.nodes.append(Node(name=part["name"], mesh=len(doc.meshes) - 1, skin=skin,
                              extras=part.get("extras") or {}))
        nodes.append(len(doc.nodes) - 1)
    return nodes


def _extension_names(items) -> set[str]:
    """Every key under an ``extensions`` object anywhere in ``items`` (nested JSON)."""
    found: set[str] = set()
    if isinstance(items, dict):
        for key, value in items.items():
            if key == "extensions" and isinstance(value, dict):
                found.update(value)
            found |= _extension_names(value)
    elif isinstance(items, list):
        for value in items:
            found |= _extension_names(value)
    return found
