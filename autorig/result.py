"""The result of rigging: what every output format writes and every caller reads."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class JointNodes:
    """A source glTF's joint hierarchy, kept so that a rig re-weighted on it is written back with the same
    joints, names, node transforms and bind pose (``autorig MESH --skeleton rig.glb``).

    names         [N] node names: the J joints first, in the rig's joint order, then the K = N - J non-joint
                  nodes above them (an armature node, a helper between two joints)
    transforms    [N] each node's local transform as the source file gives it: {"matrix": [16]} (column-major)
                  or any of {"translation": [3], "rotation": [4] (x, y, z, w), "scale": [3]}
    children      [N] lists of node indices (into ``names``)
    roots         the scene's root nodes among them
    inverse_bind  [J, 4, 4] float64 the skin's inverse bind matrices (row-major), in the rig's joint order
    skeleton      node index of the skin's ``skeleton`` property, or None
    skin_name     the skin's name
    """
    names: list[str]
    transforms: list[dict]
    children: list[list[int]]
    roots: list[int]
    inverse_bind: np.ndarray
    skeleton: int | None = None
    skin_name: str = ""


@dataclass
class Image:
    """A texture image exactly as the input file held it (never decoded): ``data`` are the file's bytes."""
    data: bytes
    mime_type: str          # "image/png" or "image/jpeg", the two that glTF 2.0 allows
    name: str = ""


@dataclass
class Look:
    """What the input looks like beyond its shape: UVs, colours, normals, materials and textures, on the
    *output vertices*. UV seams and hard edges give one input vertex several output vertices: the input's
    vertices come first, in their order (output vertex i < V is input vertex i, with the attributes of its
    first corner in the file), then the seam copies in the order they first appear.

    vertex_of      [W] int64 the input vertex each output vertex copies (W >= V; vertex_of[:V] = 0..V-1)
    faces          [F, 3] int64 the input's triangles over the output vertices, in the same order, so
                   ``vertex_of[faces] == rig.faces``
    texcoords      list of [W, 2] float32 UV sets (glTF's convention: v grows downwards from the image's top)
    colors         [W, 4] float32 linear RGBA vertex colours, or None
    normals        [W, 3] float32 unit normals from the input, or None (the writers compute them)
    face_material  [F] int64 index into ``materials`` of each triangle, -1 for none
    face_part      [F] int64 index into ``parts``: which of the input's meshes (OBJ object, glTF mesh node)
    parts          [P] {"name": str, "extras": dict}: the input's meshes, written as one mesh node each
    materials      glTF 2.0 material objects (JSON); their texture ``index`` points into ``textures``
    textures       glTF texture objects {"source": image index, "sampler": sampler index}
    samplers       glTF sampler objects
    images         [Image] the texture images, bytes untouched
    extras         the input glTF scene's ``extras``, kept on the output's scene
    dropped        [autorig.input.confine.Dropped] the input's MTL files and textures left out, and why; not written
                   as part of the look (the rig's ``info`` carries them, see ``autorig.pipeline``)
    """
    vertex_of: np.ndarray
    faces: np.ndarray
    texcoords: list[np.ndarray]
    colors: np.ndarray | None
    normals: np.ndarray | None
    face_material: np.ndarray
    face_part: np.ndarray
    parts: list[dict]
    materials: list[dict]
    textures: list[dict]
    samplers: list[dict]
    images: list[Image]
    extras: dict = field(default_factory=dict)
    dropped: list = field(default_factory=list)


@dataclass
class Rig:
    """A skeleton embedded in a mesh, with skin weights.

    All positions are in the input mesh's own coordinates and units.

    names     [J] joint names (template names, e.g. ``left_elbow``; tips end in ``_end``)
    parents   [J] int, index of each joint's parent, -1 for the root; parents come before children
    joints    [J, 3] float64 joint positions
    weights   [V, J] float64 skin weights: column j is how much vertex i follows joint j's transform
              (a joint owns the bones that leave it, as in glTF); rows are >= 0 and sum to 1
    vertices  [V, 3] float64 the input vertices, in their input order
    faces     [F, 3] int64 the input triangles
    template  name of the template that was embedded
    timings   {stage name: seconds}
    info      free-form diagnostics (detected axes, penalties, ...), JSON-serialisable
    joint_nodes  the source glTF's joint nodes when the skeleton came from one (``JointNodes``), else None:
              the glTF writers then keep its hierarchy, transforms and inverse bind matrices
    look      the input's UVs, colours, materials and textures (``Look``), or None for a bare mesh
    """
    names: list[str]
    parents: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    template: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    joint_nodes: JointNodes | None = None
    look: Look | None = None

    @property
    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) index pairs, one per non-root joint."""
        return [(int(p), j) for j, p in enumerate(self.parents) if p >= 0]

    def joint(self, name: str) -> np.ndarray:
        """Position [3] of the joint called ``name``."""
        return self.joints[self.names.index(name)]
