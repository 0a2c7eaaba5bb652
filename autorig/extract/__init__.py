"""Template-free skeletons: ``autorig.rig(mesh, "auto")`` (Wade & Parent 2002, "Automated generation of control
skeletons for use in animation", The Visual Computer 18).

For shapes no template fits (an octopus, a spider, a tree) the skeleton is read off the shape itself:

=================  ===============  ================================================================================
stage              module           what
=================  ===============  ================================================================================
voxels             ``voxels``       equal cubes around the mesh, inside where |winding number| >= 1/2
distance map       ``voxels``       EDM: each inside voxel's exact distance to the surface
medial surface     ``medial``       DMS: voxels no neighbour's inscribed ball covers; joined into one piece by
                   ``connect``      centralised routes through the solid (and gap edges between separate solids)
path tree          ``paths``        heart, extreme points, centralised paths (W = sum 1/d^3), coverage, smoothing
control skeleton   ``skeleton``     each path split where a straight bone fits it worst; generated joint names
=================  ===============  ================================================================================

The skin weights are then the same bone-heat solve as for templates (``autorig.weights.attach``). Joint names are
``root``, ``chain<c>_joint<k>`` and ``chain<c>_end`` (see ``skeleton``). ``shapes`` builds test shapes with known
branches (``star``, ``tree``).
"""
from __future__ import annotations

import numpy as np

from .connect import connected_medial, inside_graph
from .medial import medial_surface
from .paths import path_tree
from .skeleton import control_skeleton
from .voxels import distance_map, voxelize
from ..template import AUTO


__all__ = ["AUTO", "voxelize", "distance_map", "medial_surface", "inside_graph", "connected_medial", "path_tree",
           "control_skeleton", "fixed_axes", "skeleton_confidence"]


def fixed_axes(up: str, front: str) -> tuple[str, str]:
    """(up, front) with each "auto" replaced, not detected: the extraction does not depend on the axes, which
    only tell a preview or a motion which way is up. glTF's +y up and +z front, or when the other axis is given
    and lies along one of them, the next axis round."""
    up = up if up != "auto" else ("z" if front.lstrip("+-") == "y" else "y")
    front = front if front != "auto" else ("y" if up.lstrip("+-") == "z" else "z")
    return up, front


def skeleton_confidence(vertices: np.ndarray, faces: np.ndarray, joints: np.ndarray) -> tuple[float, dict[str, float]]:
    """(confidence, {part: value}) of an extracted skeleton: with no template to fit, the one part is "inside",
    the fraction of its joints (tips included: they sit on the medial surface too) inside the mesh
    (vertices [V, 3], faces [F, 3], joints [J, 3], one frame), as in ``autorig.confidence``."""
    import igl

    winding = igl.fast_winding_number(np.ascontiguousarray(vertices, dtype=np.float64),
                                      np.ascontiguousarray(faces, dtype=np.int64),
                                      np.ascontiguousarray(joints, dtype=np.float64))
    inside = float(np.mean(np.abs(winding) >= 0.5))
    return inside, {"inside": round(inside, 3)}
