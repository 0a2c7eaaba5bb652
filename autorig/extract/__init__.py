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
confidence         ``confidence``   joints inside, how clearly limbs stood out from bumps, left-right symmetry
=================  ===============  ================================================================================

The skin weights are then the same bone-heat solve as for templates (``autorig.weights.attach``). Joint names are
``root``, ``chain<c>_joint<k>`` and ``chain<c>_end`` (see ``skeleton``). ``shapes`` builds test shapes with known
branches (``star``, ``tree``).
"""
from __future__ import annotations

from .confidence import skeleton_confidence, skeleton_reasons
from .connect import connected_medial, inside_graph
from .medial import medial_surface
from .paths import path_tree
from .skeleton import control_skeleton
from .voxels import distance_map, voxelize
from ..template import AUTO


__all__ = ["AUTO", "voxelize", "distance_map", "medial_surface", "inside_graph", "connected_medial", "path_tree",
           "control_skeleton", "fixed_axes", "skeleton_confidence", "skeleton_reasons"]


def fixed_axes(up: str, front: str) -> tuple[str, str]:
    """(up, front) with each "auto" replaced, not detected: the extraction does not depend on the axes, which
    only tell a preview or a motion which way is up. glTF's +y up and +z front, or when the other axis is given
    and lies along one of them, the next axis round."""
    up = up if up != "auto" else ("z" if front.lstrip("+-") == "y" else "y")
    front = front if front != "auto" else ("y" if up.lstrip("+-") == "z" else "z")
    return up, front
