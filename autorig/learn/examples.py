"""Rigged characters to learn from: the corpus layout (``joints.json`` with a template map, ``mesh.obj``,
``weights.npz``) or rigged glTF files (a studio's own characters sharing one skeleton).

Every example is brought into the template frame by ``autorig.input.mesh.prepare`` (+y up, facing +z, one unit tall,
feet at y = 0, the bounding box centred in x and z), so that positions of different characters can be averaged.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, TemplateError
from ..template import Template

GLTF_SUFFIXES = (".glb", ".gltf")


@dataclass
class Example:
    """One rigged character.

    name       what reports call it
    vertices   [V, 3] mesh vertices, in the file's coordinates
    faces      [F, 3] triangles
    up, front  the file's axes ('y', 'z', ...)
    names      [J] the example's own joint names
    parents    [J] parent index of each joint, -1 for a root
    positions  [J, 3] joint positions in the file's coordinates
    weights    [V, J] the artist's skin weights (rows sum to 1)
    key_of     {template joint name: example joint index} for the joints the example has
    meta       the corpus's joints.json (without its joints), or {} for a glTF file
    source     the studio, game or tool it comes from (``conventions.source_of``)
    """
    name: str
    vertices: np.ndarray
    faces: np.ndarray
    up: str
    front: str
    names: list[str]
    parents: np.ndarray
    positions: np.ndarray
    weights: np.ndarray
    key_of: dict[str, int] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    source: str = ""

    def prepared(self):
        """The mesh in the template frame (``autorig.input.mesh.PreparedMesh``), centred on the body's mid-plane as
        a rig centres it (``orient.centre_on_mid_plane``), made once."""
        if "_prepared" not in self.__dict__:
            from ..discretize.surface import SurfaceQuery
            from ..input.mesh import check_mesh, prepare
            from ..embed.orient import mid_plane
            V, F = check_mesh(self.vertices, self.faces, self.name)
            prepared = prepare(V, F, self.up, self.front, name=self.name, checked=True)
            x = mid_plane(SurfaceQuery(*prepared.coarse()).distance, prepared.work_vertices)
            self.__dict__["_prepared"] = prepared.centred_at(x)
        return self.__dict__["_prepared"]

    def canonical_joints(self) -> np.ndarray:
        """[J, 3] the example's joints in the template frame."""
        return self.prepared().to_canonical(self.positions)

    def descendants(self, j: int) -> list[int]:
        """Joint j and every joint below it in the example's own hierarchy."""
        out, frontier = [], [j]
        while frontier:
            k = frontier.pop()
            out.append(k)
            frontier.extend(int(c) for c in np.flatnonzero(self.parents == k))
        return out


def expand(paths) -> list[Path]:
    """The example files and folders named by ``paths``: a corpus folder (with ``joints.json``), a folder of
    such folders or of rigged glTF files (in name order), or a rigged glTF file."""
    out = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir() and (path / "joints.json").is_file():
            out.append(path)
        elif path.is_dir():
            found = sorted(p for p in path.iterdir() if (p.is_dir() and (p / "joints.json").is_file())
                           or p.suffix.lower() in GLTF_SUFFIXES)
            if not found:
                raise InputError(f"{path}: no rigged characters in it (corpus folders or .glb/.gltf files)")
            out.extend(found)
        elif path.is_file() and path.suffix.lower() in GLTF_SUFFIXES:
            out.append(path)
        else:
            raise InputError(f"{path}: not a rigged .glb/.gltf file or a corpus folder")
    return out


def read_example(path: Path, base: Template | None = None) -> Example | None:
    """The example at ``path`` (see ``expand``). A corpus folder needs ``base``; it is read with the map of
    the base template's joint names in its ``joints.json`` and None is returned when it has none (a bird
    in a folder of quadrupeds)."""
    if path.is_dir():
        if base is None:
            raise TemplateError(f"{path}: a corpus folder needs --template, the template its map names")
        return _read_corpus(path, base)
    return _read_gltf(path)


def _read_corpus(folder: Path, base: Template) -> Example | None:
    from ..input.mesh import load_mesh
    try:
        meta = json.loads((folder / "joints.json").read_text())
        joints = meta.pop("joints")
        names = [j["name"] for j in joints]
        index = {n: i for i, n in enumerate(names)}
        parents = np.array([index[j["parent"]] if j["parent"] is not None else -1 for j in joints], dtype=np.int64)
        positions = np.array([j["position"] for j in joints], dtype=float)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{folder}/joints.json: not a corpus joints file ({e})") from None
    from .humanoid_map import with_humanoid_map
    # The humanoid's extra joints are read off the hierarchy of a rig that maps only the biped's.
    mapping = _best_map(with_humanoid_map(meta, joints), base, index)
    if mapping is None:
        return None
    vertices, faces = load_mesh(folder / "mesh.obj")
    with np.load(folder / "weights.npz") as npz:
        weights = np.asarray(npz["weights"], dtype=float)
    if weights.shape != (len(vertices), len(names)):
        raise InputError(f"{folder}: weights {weights.shape} do not match the mesh and joints")
    up, front = (_axis(meta.get(k, d), folder) for k, d in (("up_axis", "+y"), ("front_axis", "+z")))
    return Example(name=folder.name, vertices=vertices, faces=faces, up=up, front=front, names=names,
                   parents=parents, positions=positions, weights=weights,
                   key_of={k: index[v] for k, v in mapping.items() if v is not None}, meta=meta)


def _best_map(meta: dict, base: Template, index: dict) -> dict | None:
    """The ``*_map`` of joints.json whose keys are the base template's joint names (most of them), if any."""
    names = set(base.names)
    best, best_cover = None, 0
    for key, value in meta.items():
        if not key.endswith("_map") or not isinstance(value, dict) or not set(value) <= names:
            continue
        mapped = {k: v for k, v in value.items() if v is not None and v in index}
        if len(mapped) > best_cover:
            best, best_cover = mapped, len(mapped)
    return best


def _axis(spec: str, where) -> str:
    spec = str(spec).lstrip("+")
    if spec.lstrip("-") not in ("x", "y", "z"):
        raise InputError(f"{where}: unknown axis {spec!r}")
    return spec


def _read_gltf(path: Path) -> Example:
    from ..exchange.gltf import read_glb
    rig = read_glb(path)
    # glTF is +y up, facing +z by its specification.
    return Example(name=path.stem, vertices=rig.vertices, faces=rig.faces, up="y", front="z",
                   names=list(rig.names), parents=np.asarray(rig.parents, dtype=np.int64),
                   positions=np.asarray(rig.joints, dtype=float), weights=np.asarray(rig.weights, dtype=float),
                   key_of={n: i for i, n in enumerate(rig.names)})


def read_mapped_gltf(path: Path, map_file: Path, base: Template) -> Example | None:
    """The rigged glTF file ``path`` with the template map of ``map_file`` (a JSON object as a corpus
    ``joints.json`` without its joints: ``<template>_map`` {template joint: the file's joint name or null},
    ``up_axis``/``front_axis`` (default +y/+z, glTF's), ``source_group``), e.g. ``data/maps/openclonk_wipf.json``.
    None when the map names none of the base template's joints."""
    try:
        meta = json.loads(Path(map_file).read_text())
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as e:
        raise InputError(f"{map_file}: not a template map ({e})") from None
    example = _read_gltf(Path(path))
    index = {n: i for i, n in enumerate(example.names)}
    mapping = _best_map(meta, base, index)
    if mapping is None:
        return None
    example.name = str(meta.get("name") or example.name)
    example.up, example.front = (_axis(meta.get(k, d), map_file) for k, d in (("up_axis", "+y"),
                                                                             ("front_axis", "+z")))
    example.key_of = {k: index[v] for k, v in mapping.items()}
    example.meta = meta
    from .conventions import source_of
    example.source = source_of(example, Path(path))
    return example


def read_examples(paths, base: Template | None = None) -> list[Example]:
    """Every example under ``paths`` (see ``expand``) that has the base template's joints; an ``Example``
    among them (``read_mapped_gltf``'s) is taken as it is."""
    from .conventions import source_of
    examples = []
    for item in paths:
        if isinstance(item, Example):
            item.source = item.source or source_of(item)
            examples.append(item)
            continue
        for path in expand([item]):
            example = read_example(path, base)
            if example is not None:
                example.source = source_of(example, path)
                examples.append(example)
    if len(examples) < 2:
        raise InputError(f"learning a template needs at least two rigged characters, found {len(examples)}")
    return examples
