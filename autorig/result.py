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

    @property
    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) index pairs, one per non-root joint."""
        return [(int(p), j) for j, p in enumerate(self.parents) if p >= 0]

    def joint(self, name: str) -> np.ndarray:
        """Position [3] of the joint called ``name``."""
        return self.joints[self.names.index(name)]
