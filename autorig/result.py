"""The result of rigging: what every output format writes and every caller reads."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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

    @property
    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) index pairs, one per non-root joint."""
        return [(int(p), j) for j, p in enumerate(self.parents) if p >= 0]

    def joint(self, name: str) -> np.ndarray:
        """Position [3] of the joint called ``name``."""
        return self.joints[self.names.index(name)]
