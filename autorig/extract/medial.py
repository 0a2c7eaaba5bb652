"""Stage 3 of the template-free skeleton: the discrete medial surface (DMS) of a voxelized solid.

The medial surface is the set of centres of maximal inscribed balls. In the EDM, a voxel v off the medial
surface has a neighbour n further from the boundary by (almost) the step between them, d(n) ~ d(v) + |n - v|,
whose ball (nearly) swallows v's own: the EDM climbs at slope 1 along the direction to the medial surface. On
the medial surface the EDM climbs at a slope of cos(a/2) at most, where a is the angle between the two nearest
boundary points as seen from the voxel (a ~ 180 degrees across a limb, where the slope is ~0).

The rule: a voxel v is on the DMS when no one of its 26 neighbours n covers it,

    d(n) - d(v) < COVER_SLOPE * |n - v|    for every neighbour n.

COVER_SLOPE = 1/2 keeps the ridges of parts whose boundary points are more than 120 degrees apart (limbs, the
middle of a torso) and drops the medial sheets that run out into sharper convex edges (a box's 90-degree edges:
slope 0.71) and the rims of the sheets in flat parts, which carry no limb. With the exact EDM of
``voxels.distance_map`` the result is one to two voxels thick along limbs and a sheet in the middle of flat
parts; it is in pieces wherever a limb flares into the body (see ``connect``).
"""
from __future__ import annotations

import numpy as np

COVER_SLOPE = 0.5

# The 26 neighbour offsets of a voxel [26, 3] and their lengths [26].
NEIGHBOURS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                       if (i, j, k) != (0, 0, 0)], dtype=np.int64)
NEIGHBOUR_LENGTHS = np.linalg.norm(NEIGHBOURS, axis=1)


def medial_surface(depth: np.ndarray) -> np.ndarray:
    """The DMS of the solid whose EDM is depth [X, Y, Z] (voxels; 0 outside, outermost layer empty).

    Returns the DMS voxels [M, 3] int64 grid coordinates, in C (x-major) order.
    """
    core = depth[1:-1, 1:-1, 1:-1]
    medial = core > 0
    shape = np.array(depth.shape) - 2
    for offset, length in zip(NEIGHBOURS, NEIGHBOUR_LENGTHS):
        lo = 1 + offset
        neighbour = depth[lo[0]:lo[0] + shape[0], lo[1]:lo[1] + shape[1], lo[2]:lo[2] + shape[2]]
        medial &= neighbour - core < COVER_SLOPE * length
    return np.argwhere(medial) + 1
