"""Stages 1 and 2 of the template-free skeleton: voxelize the solid, then its Euclidean distance map (EDM).

The grid is a box of equal cubes around the mesh in the canonical frame, the box's longest side ``resolution``
cells long, with at least one empty layer of cells all round (so that every inside voxel has its 26 neighbours
in the grid) and an odd number of cells along each axis, centred on the middle of the mesh's box. A voxel is
inside when the generalized winding number at its centre is at least 1/2 in magnitude: this gives open,
self-intersecting and multi-part meshes a meaningful inside, and the magnitude (not the sign) keeps parts that
face inward solid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RigFailedError

BLOCK = 4    # voxels along a block's side in the inside test


@dataclass(frozen=True)
class VoxelGrid:
    """A voxelized solid.

    origin  [3] canonical position of the centre of voxel (0, 0, 0)
    step    edge length of a voxel, canonical units (the mesh is one unit tall)
    inside  [X, Y, Z] bool, voxels whose centre is inside the solid; the outermost layer is always False
    extent  [3] the size of the mesh's bounding box, in voxels (None: the grid's, less its margin)
    """
    origin: np.ndarray
    step: float
    inside: np.ndarray
    extent: np.ndarray | None = None

    @property
    def diagonal(self) -> float:
        """The diagonal of the mesh's bounding box, in voxels."""
        extent = self.extent if self.extent is not None else np.array(self.inside.shape) - 2
        return float(np.linalg.norm(extent))

    def centres(self, index: np.ndarray) -> np.ndarray:
        """Canonical positions [N, 3] of the centres of voxels index [N, 3] (integer grid coordinates)."""
        return self.origin + np.asarray(index, dtype=np.float64) * self.step


def voxelize(vertices: np.ndarray, faces: np.ndarray, resolution: int) -> VoxelGrid:
    """Inside/outside of every voxel of a grid around the mesh.

    vertices [V, 3], faces [F, 3]: the mesh in the canonical frame. resolution: cells along the bounding box's
    longest side (>= 8).
    """

    if resolution < 8:
        raise ValueError(f"voxel resolution must be at least 8, got {resolution}")
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    step = float((hi - lo).max()) / resolution
    # An odd count along each axis, the mesh's extent and at least one cell of margin on each side, centred on
    # the middle of the mesh's box: a voxel centre sits at the middle, so a mirror-symmetric mesh has its plane
    # of symmetry through a layer of voxel centres (not between two layers, where which of the two holds its
    # medial surface is a tie the least change of the mesh flips), and the lattice moves with the mesh as it
    # moves: rounding that adds a cell adds one on each side, never shifts the others by half a cell.
    counts = 2 * np.ceil((hi - lo) / (2 * step)).astype(np.int64) + 3
    origin = (lo + hi) / 2 - step * (counts - 1) / 2
    inside = _inside(np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64),
                     origin, step, counts)
    # The margin must stay empty; only a winding number gone astray (a wildly open mesh) could fill it.
    inside[[0, -1], :, :] = inside[:, [0, -1], :] = inside[:, :, [0, -1]] = False
    if not inside.any():
        raise RigFailedError(f"no voxel centre is inside the mesh at {resolution} voxels: it is thinner than a "
                             f"voxel, or not closed; use more voxels")
    return VoxelGrid(origin, step, inside, (hi - lo) / step)


def _inside(vertices: np.ndarray, faces: np.ndarray, origin: np.ndarray, step: float, counts: np.ndarray) -> np.ndarray:
    """[X, Y, Z] bool (counts [3]): |winding number| >= 1/2 at each voxel centre (origin [3], step).

    The winding number is evaluated at every voxel only in blocks of BLOCK^3 voxels that the surface passes
    near; a block further from every face than its half-diagonal is all inside or all outside, and so is every
    block connected to it through such blocks: one number at one block's centre decides them all."""
    import igl
    from scipy import ndimage

    blocks = -(-counts // BLOCK)
    block_axes = [origin[k] + step * (BLOCK * np.arange(blocks[k]) + (BLOCK - 1) / 2) for k in range(3)]
    block_centres = np.stack(np.meshgrid(*block_axes, indexing="ij"), axis=-1).reshape(-1, 3)
    tree = igl.AABB()
    tree.init(vertices, faces)
    squared, _, _ = tree.squared_distance(vertices, faces, block_centres)
    # Half the block's diagonal, and a little more so that rounding never misjudges a block the surface grazes.
    plain = squared > (0.5 * np.sqrt(3) * BLOCK * step * 1.01) ** 2
    # The winding number is the same all through a region the surface does not cross: one number per
    # connected run of plain blocks (two face-adjacent plain blocks make one surface-free box).
    runs, count = ndimage.label(plain.reshape(tuple(blocks)))
    runs = runs.ravel()
    first = np.unique(runs, return_index=True)[1][1:]           # one block of each run (label 0: not plain)
    run_inside = np.zeros(count + 1, dtype=bool)
    run_inside[runs[first]] = np.abs(igl.fast_winding_number(vertices, faces, block_centres[first])) >= 0.5
    block_inside = run_inside[runs] & plain
    inside = np.repeat(np.repeat(np.repeat(block_inside.reshape(tuple(blocks)), BLOCK, 0), BLOCK, 1), BLOCK, 2)
    inside = inside[:counts[0], :counts[1], :counts[2]]
    # Every voxel of the blocks near the surface.
    near = np.zeros(tuple(blocks), dtype=bool)
    near.flat[np.flatnonzero(~plain)] = True
    fine = np.repeat(np.repeat(np.repeat(near, BLOCK, 0), BLOCK, 1), BLOCK, 2)[:counts[0], :counts[1], :counts[2]]
    voxels = np.argwhere(fine)
    inside[tuple(voxels.T)] = np.abs(igl.fast_winding_number(vertices, faces, origin + step * voxels)) >= 0.5
    return inside


def distance_map(grid: VoxelGrid, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """EDM [X, Y, Z] of the voxelized solid: for each inside voxel of ``grid`` the distance (in voxels) from its
    centre to the mesh (vertices [V, 3], faces [F, 3], canonical frame), 0 outside (and on the surface itself,
    where a voxel centre counts as outside from here on).

    The distance is the exact one to the triangles (libigl's AABB tree), not the voxel distance transform
    (scipy's ``distance_transform_edt``, which measures to the nearest outside voxel centre): that one is off
    by up to ~0.9 voxel depending on how the surface lies across the grid, and the medial test, which compares
    neighbouring depths, turns those steps into spurious medial voxels all over the surface (at 96 voxels:
    65 medial pieces instead of 9 on the octopus, 157 instead of 38 on the armadillo). It costs ~0.7 s on
    60k inside voxels of a 86k-triangle mesh, against 0.06 s. The distance is to the solid's boundary only
    (``deepest_in_parts``): in a model of overlapping parts the faces buried in another part are not surface.
    """
    import igl

    voxels = np.argwhere(grid.inside)
    tree = igl.AABB()
    V, F = np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64)
    tree.init(V, F)
    squared, nearest, _ = tree.squared_distance(V, F, grid.centres(voxels))
    depth = np.zeros(grid.inside.shape)
    depth[tuple(voxels.T)] = np.sqrt(squared) / grid.step
    return deepest_in_parts(depth, grid, V, F, voxels, nearest)


def deepest_in_parts(depth: np.ndarray, grid: VoxelGrid, vertices: np.ndarray, faces: np.ndarray,
                     voxels: np.ndarray, nearest: np.ndarray) -> np.ndarray:
    """depth [X, Y, Z] (the distance to every face, in voxels) raised, inside each separate part of a mesh whose
    parts overlap, to the distance to that part's own surface. In a model of overlapping parts (a leg pushed
    into a body) the surface of one part inside another is no surface: its distance would cut the depth inside
    the body down to the buried leg and scatter medial voxels all through it. The deepest any part holds a
    voxel is the distance to the union's surface but near the seams, where it is a little less.

    voxels [N, 3] the inside voxels, nearest [N] the face nearest to each: only those nearest to a buried face
    can be wrong."""
    import igl

    V, F = np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64)
    count, part = _vertex_parts(len(V), F)
    if count < 2:
        return depth
    # A surface point buried in another part has a winding number of 1/2 from its own part and 1 more.
    buried = np.abs(igl.fast_winding_number(V, F, V)) >= 1.0
    voxels = voxels[buried[F[nearest]].any(axis=1)]
    if len(voxels) == 0:
        return depth
    centres = grid.centres(voxels)
    face_part = part[F[:, 0]]
    for k in range(count):
        own = F[face_part == k]
        if len(own) < 4:
            continue
        corners = V[np.unique(own)]
        near = np.flatnonzero(np.all((centres >= corners.min(axis=0)) & (centres <= corners.max(axis=0)), axis=1))
        inside = near[np.abs(igl.fast_winding_number(V, own, centres[near])) >= 0.5]
        if len(inside) == 0:
            continue
        tree = igl.AABB()
        tree.init(V, own)
        squared, _, _ = tree.squared_distance(V, own, centres[inside])
        index = tuple(voxels[inside].T)
        depth[index] = np.maximum(depth[index], np.sqrt(squared) / grid.step)
    return depth


def _vertex_parts(n: int, faces: np.ndarray) -> tuple[int, np.ndarray]:
    """(number of parts, part of each of the n vertices [n]): the connected pieces of the faces [F, 3]."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]])
    return connected_components(coo_matrix((np.ones(len(edges)), tuple(edges.T)), shape=(n, n)), directed=False)
