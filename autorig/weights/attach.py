"""Skin attachment: bone-heat weights (Baran & Popović 2007, "Automatic Rigging and Animation of 3D
Characters", section 4).

Each bone b is treated as a heat source that warms the surface points it is the nearest visible bone of; the
equilibrium temperature of the surface is the bone's weight:

    (-Δ + H) w_b = H p_b,

with Δ the surface Laplacian, H_ii = c / d_i^2 (d_i: distance from vertex i to its nearest visible bone,
H_ii = 0 where no bone is visible) and p_b,i = 1 when b is that nearest visible bone. Discretised with the
stiffness matrix K (positive semidefinite, K = -cot Laplacian) and the lumped mass matrix M this is

    (K + M H) w_b = M H p_b,

one symmetric positive definite matrix for every bone, factorised once and solved for all bones at once.
Because the p_b sum to 1 at every heated vertex and K annihilates constants, the w_b sum to 1 as well.

Real meshes are not the clean manifolds the paper assumes, so the surface is first welded (coincident
vertices share weights, so UV-seam splits do not tear when posed) and faces that collapse are dropped;
meshes with zero-area or sliver faces get the intrinsic Delaunay Laplacian; parts of the mesh that see no
bone at all (a helmet over the head, a coat over the body) are heated by their Euclidean-nearest bones
instead of being left without a heat source; vertices on no face follow the closest surface vertex.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..input.facing import unique_ints
from ..input.budget import HEAT_BYTES, checkpoint, over_memory
from .pieces import follow_body

HEAT_C = 2.0            # c in H_ii = c / d_i^2. The paper uses 1; 2 is closer to artists' sharper weights
                        # (benchmarks/weights_on_gt_skeleton.py: mean L1 -25% to -30%, top-1 no worse)
TIE_RATIO = 1.0001      # bones this close to the nearest one share its heat (vertices beyond a joint)
WEIGHT_FLOOR = 1e-4     # smaller weights are noise of the diffusion: dropped, as Pinocchio does
WELD_TOL = 1e-7         # vertices closer than this (x bounding-box diagonal) are one surface point
MIN_DIST = 1e-5         # floor of d_i (x diagonal), so a bone touching the surface does not give H = inf
COT_LIMIT = 100.0       # a face with a larger |cot| (an angle under ~0.6 degrees from 0 or 180) is a sliver
RAY_NUDGE = 1e-3        # sideways offset of visibility rays, in units of a short edge (see sees_bone)
HEAT_MAX_VERTICES = 12_000  # denser surfaces are solved on a simplified copy (see _weights_via_coarse_surface)
_GENERIC_DIRECTION = np.array([0.5377, 0.8335, 0.1274]) / np.linalg.norm([0.5377, 0.8335, 0.1274])


def bone_heat(vertices, faces, joints, parents, *, owners=None, surface=None, height=None) -> np.ndarray:
    """Bone-heat skin weights of a mesh for a skeleton.

    vertices [V, 3] float: the mesh as given (may be multi-part, open, non-manifold, with duplicate vertices
        and degenerate faces); the weights are for these vertices, in this order.
    faces    [F, 3] int: triangles indexing ``vertices``.
    joints   [J, 3] float: joint positions, in the mesh's frame.
    parents  [J] int: parent joint of each joint, -1 for a root; parents come before their children.
    owners   [J] int, optional: for each non-root joint c, the weight column that receives the heat of the
        bone parent(c) -> c. Default ``parents``: a joint owns the bones that leave it, as in glTF skinning.
    surface  optional: ``heat_surface(vertices, faces)``, made beforehand (``autorig.weights.ahead``).
    height   the character's height in the mesh's units, for telling separate pieces' sizes
        (``autorig.weights.pieces``: pieces not connected to the body take its weights); None: the longest side.

    Returns W [V, J] float64: W[i, j] is how much vertex i follows joint j's transform. Rows are >= 0 and sum
    to 1; joints that own no bone (tips) get zero columns. A skeleton without any bone (a single joint) gets
    every vertex on its first root.
    """
    V = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    P = np.asarray(joints, dtype=np.float64).reshape(-1, 3)
    parents = np.asarray(parents, dtype=np.int64).reshape(-1)
    owners = parents if owners is None else np.asarray(owners, dtype=np.int64).reshape(-1)
    _check_inputs(V, F, P, parents, owners)

    n_joints = len(P)
    W = np.zeros((len(V), n_joints))
    if len(V) == 0:
        return W
    bone_child = np.flatnonzero(parents >= 0)                        # bone b runs parents[c] -> c, c = bone_child[b]
    # The dense arrays: three [vertices, bones] (distances, their order, the weights) and two [vertices, joints].
    over_memory("the bone heat", 8 * len(V) * (3 * len(bone_child) + 2 * n_joints), HEAT_BYTES,
                f"{len(V):,} vertices and {len(bone_child):,} bones")
    if len(bone_child) == 0:
        W[:, int(np.flatnonzero(parents < 0)[0])] = 1.0
        return W

    weld, Vw, Fw, coarse, laplacian = surface or heat_surface(V, F)
    heads, tails = P[parents[bone_child]], P[bone_child]
    if coarse is not None:           # pieces follow their body on the copy: each dense vertex lies on its part's
        Wb = _weights_via_coarse_surface(coarse, heads, tails, laplacian, height)
    else:
        Wb = _bone_weights(Vw, Fw, heads, tails, laplacian)          # [U, B] on welded vertices
        Wb = follow_body(Vw, Fw, Wb, height, (heads, tails))         # pieces go with the body they sit on
    to_joint = np.zeros((len(bone_child), n_joints))                 # bone -> owning joint column
    to_joint[np.arange(len(bone_child)), owners[bone_child]] = 1.0
    return np.take(Wb @ to_joint, weld, axis=0)                      # = (Wb @ to_joint)[weld], faster


def heat_surface(V, F):
    """The surface the heat is solved on and its Laplacian, which depend on the mesh alone (not the skeleton):
    (weld [V], Vw [U, 3], Fw [F', 3]) of ``weld_surface``; coarse: when Vw has more than HEAT_MAX_VERTICES
    vertices its simplified copy and where the dense vertices lie on it (``_coarse_copy``), else None;
    laplacian: ``surface_laplacian`` of the surface solved on (the copy, or Vw, Fw).

    Heat equilibria are smooth, so a surface of HEAT_MAX_VERTICES vertices resolves them; past that the
    factorisation and the visibility rays only cost time and memory (a 1M-face scan)."""
    weld, Vw, Fw = weld_surface(np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))
    if len(Vw) <= HEAT_MAX_VERTICES:
        return weld, Vw, Fw, None, surface_laplacian(Vw, Fw)
    coarse = _coarse_copy(Vw, Fw)
    return weld, Vw, Fw, coarse, surface_laplacian(*coarse[:2])


def start_heat_surface(prepared) -> "HeatSurfaceAhead":
    """``heat_surface`` of a prepared mesh's vertices and faces (``autorig.input.mesh.PreparedMesh``), begun now on the
    second core (``autorig.weights.ahead``) when the mesh is dense enough to be simplified for the heat; its
    ``result_for`` gives it to ``bone_heat``'s ``surface``.

    Below that the work is mostly too small to pay for the fork: the pages a forked process shares with its
    parent are copied when the parent writes to them (every Python object whose reference count changes), some
    0.05 s of a 20k-face rig, as much as the heat surface's 0.04 s (60k faces: 0.15 s; 1M: ~2 s). A surface
    with slivers is the exception: with its intrinsic Delaunay Laplacian (``surface_laplacian``) it takes 0.06 s
    of CPU at 10k vertices, and made ahead the rig's own CPU falls 0.99 -> 0.93 s (20k-face benchmark
    mannequin); under ~3k vertices the fork and the work are both a few ms, a wash either way."""
    return HeatSurfaceAhead(prepared)


def _worth_ahead(prepared) -> bool:
    """Whether a prepared mesh's heat surface costs enough to be made in a child: dense enough to be simplified,
    or with slivers (checked on the input's faces, ~3 ms at 20k faces; the welded surface the heat uses
    differs only by faces that collapse, so at worst a fork is spent or saved in vain: the value is the same)."""
    if len(prepared.work_vertices) > HEAT_MAX_VERTICES:
        return True
    V = np.asarray(prepared.vertices, dtype=np.float64)
    return not np.all(np.abs(face_cotangents(V, np.asarray(prepared.faces, dtype=np.int64))) <= COT_LIMIT)


class HeatSurfaceAhead:
    """``heat_surface`` begun for a prepared mesh (see ``start_heat_surface``)."""

    def __init__(self, prepared):
        from .ahead import Ahead
        self._prepared = prepared
        self._ahead = Ahead(heat_surface, (prepared.vertices, prepared.faces),
                            wanted=_worth_ahead(prepared))

    def result_for(self, prepared):
        """``heat_surface(prepared.vertices, prepared.faces)`` if it was begun for this very mesh, or the same for
        the same mesh before the orientation moved it along x to the body's mid-plane (``PreparedMesh.centred_at``;
        the welded positions are then taken from the moved mesh, the simplified copy moved along, equal to
        rounding); None when it was not begun or the mesh was turned to other axes since (``bone_heat`` then
        makes it)."""
        start = self._prepared
        moved = (prepared is not start and prepared.faces is start.faces and prepared.scale == start.scale
                 and np.array_equal(prepared.rotation, start.rotation))
        if prepared is not start and not moved:
            self._ahead.result_if(None)    # stops the child
            return None
        value = self._ahead.result_if(start.vertices, start.faces)
        if value is None or not moved:
            return value
        weld, Vw, Fw, coarse, laplacian = value
        first = np.unique(weld, return_index=True)[1]                 # each welded vertex's first input vertex
        Vw = np.asarray(prepared.vertices, dtype=np.float64)[first]
        if coarse is not None:
            shift = value[1][0] - Vw[0]
            coarse = (coarse[0] - shift, *coarse[1:])
        return weld, Vw, Fw, coarse, laplacian


def _coarse_copy(V, F):
    """The simplified copy of a dense welded surface V [U, 3], F [G, 3] that the heat is solved on, and where
    each dense vertex lies on it: (vertices [U', 3], faces [G', 3], corners [U, 3] the copy's vertices of the
    triangle closest to each dense vertex, bary [U, 3] the closest point's barycentric coordinates there).

    A dense vertex lies on the copy of its own connected part: simplification keeps parts apart, but the
    closest copy triangle of a fingertip under a nail can be the nail's (whose heat, from the bones it sees
    through the gap between the fingers, is not the finger's); each dense part goes with the copy's part most
    of its vertices are closest to, and the vertices closest to another part are put on that one's."""
    import fast_simplification
    import igl

    coarse_V, coarse_F = fast_simplification.simplify(V, F.astype(np.int32), target_count=2 * HEAT_MAX_VERTICES)
    coarse_V, coarse_F = np.asarray(coarse_V, dtype=np.float64), np.asarray(coarse_F, dtype=np.int64)
    tree = igl.AABB()
    tree.init(coarse_V, coarse_F)
    _, face, closest = tree.squared_distance(coarse_V, coarse_F, V)
    face = np.asarray(face, dtype=np.int64)
    dense_part, coarse_part = _parts(V, F), _parts(coarse_V, coarse_F)
    landed = coarse_part[coarse_F[face, 0]]
    on = dense_part >= 0
    votes = sp.coo_matrix((np.ones(int(on.sum())), (dense_part[on], landed[on]))).tocsr()
    own = np.where(on, np.asarray(votes.argmax(axis=1)).ravel()[dense_part], landed)   # [U] the copy's part
    stray = np.flatnonzero(landed != own)
    for part in unique_ints(own[stray]):
        at = stray[own[stray] == part]
        faces = np.flatnonzero(coarse_part[coarse_F[:, 0]] == part)
        _, k, closest[at] = igl.point_mesh_squared_distance(V[at], coarse_V, coarse_F[faces])
        face[at] = faces[np.asarray(k, dtype=np.int64)]
    corners = coarse_F[face]
    bary = igl.barycentric_coordinates(closest, coarse_V[corners[:, 0]], coarse_V[corners[:, 1]],
                                       coarse_V[corners[:, 2]])
    bary = np.clip(np.nan_to_num(bary, nan=1.0 / 3.0), 0.0, None)
    bary /= bary.sum(axis=1, keepdims=True)
    return coarse_V, coarse_F, corners, bary


def _parts(V, F):
    """[U] the connected part of each vertex of V [U, 3] over the faces F; -1 for a vertex on no face."""
    n = len(V)
    adj = sp.coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, 1, axis=1).ravel())), shape=(n, n))
    _, label = connected_components(adj, directed=False)
    on_face = np.zeros(n, bool)
    on_face[F.ravel()] = True
    return np.where(on_face, label, -1)


def _weights_via_coarse_surface(coarse, heads, tails, laplacian=None, height=None):
    """Bone weights [U, B] of a dense surface's vertices, solved on its simplified copy ``coarse``
    (``_coarse_copy``; laplacian: the copy's, if made already), where the separate pieces then take the weights
    of the body they sit on (``follow_body``; height as ``bone_heat`` takes it). Each dense vertex takes the
    weights at its closest point on the copy of its own part, interpolated across that triangle: a rigid
    piece's one row stays one row, and the pieces' closest points are sought among the copy's vertices
    (the ogre's 62k: 0.66 -> 0.1 s)."""
    coarse_V, coarse_F, corners, bary = coarse
    W = follow_body(coarse_V, coarse_F, _bone_weights(coarse_V, coarse_F, heads, tails, laplacian), height,
                    (heads, tails))
    # Corner by corner: W[corners] at once would be a [U, 3, B] temporary (280 MB for a 1M-face scan). Rows
    # gathered by np.take and scaled in place: the same products and sums, 0.26 -> 0.16 s for [500k, 23].
    dense = np.take(W, corners[:, 0], axis=0)
    dense *= bary[:, 0, None]
    for k in (1, 2):
        part = np.take(W, corners[:, k], axis=0)
        part *= bary[:, k, None]
        dense += part
    return _clean(dense)


def _check_inputs(V, F, P, parents, owners):
    """Raise ValueError on arrays that do not describe a mesh and a skeleton (shapes [V,3], [F,3], [J,3], [J])."""
    n = len(P)
    if len(parents) != n or len(owners) != n:
        raise ValueError(f'{n} joints but {len(parents)} parents and {len(owners)} owners')
    if n == 0:
        raise ValueError('a skeleton needs at least one joint')
    if np.any(parents >= np.arange(n)) or np.any(parents < -1):
        raise ValueError('parents must be -1 or the index of an earlier joint')
    if np.any((parents >= 0) & ((owners < 0) | (owners >= n))):
        raise ValueError('owners must give a joint index for every non-root joint')
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError('faces index missing vertices')
    if not (np.isfinite(V).all() and np.isfinite(P).all()):
        raise ValueError('vertices and joints must be finite')


def weld_surface(V, F):
    """Merge coincident vertices and drop faces that collapse.

    V [V, 3], F [F, 3]. Returns (weld [V] index of each input vertex in the welded set, Vw [U, 3] welded
    positions, Fw [F', 3] faces on Vw with three distinct corners). Faces of zero area whose corners are
    distinct are kept (surface_laplacian handles them): dropping them could cut a thin part in two.
    """
    diag = float(np.linalg.norm(np.ptp(V, axis=0))) or 1.0
    keys = np.round(V / (WELD_TOL * diag)).astype(np.int64)
    _, first, weld = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    weld = weld.reshape(-1)
    # np.unique sorts the keys; renumber in order of first appearance so that the output is independent of
    # the sort and the welded vertices keep the input's order.
    order = np.argsort(first, kind='stable')
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    weld = rank[weld]
    Vw = V[first[order]]
    Fw = weld[F]
    distinct = (Fw[:, 0] != Fw[:, 1]) & (Fw[:, 1] != Fw[:, 2]) & (Fw[:, 0] != Fw[:, 2])
    return weld, Vw, Fw[distinct]


def _bone_weights(V, F, heads, tails, laplacian=None):
    """Heat weights of each bone on a welded mesh.

    V [U, 3], F [F, 3] (no repeated corners); heads, tails [B, 3] bone end points; laplacian: its
    ``surface_laplacian``, if made already. Returns W [U, B], rows >= 0 summing to 1.
    """
    dist = segment_distances(V, heads, tails)                        # [U, B]
    W = nearest_share(dist)                                          # kept only where there is no surface
    on_face = np.zeros(len(V), bool)
    on_face[F.ravel()] = True
    surf = np.flatnonzero(on_face)
    if len(surf):
        scale = float(np.linalg.norm(np.ptp(V, axis=0))) or 1.0
        near, dmin = nearest_visible_bones(V, F, heads, tails, dist, surf)
        _heat_hidden_parts(V, F, surf, dist[surf], near, dmin)
        W[surf] = solve_heat(V, F, surf, near, np.maximum(dmin, MIN_DIST * scale), laplacian)
        # A vertex on no face (unreferenced, or only on faces that the weld collapsed) has no surface to
        # diffuse over: it moves with the closest surface point, so it stays with the part it belongs to.
        loose = np.flatnonzero(~on_face)
        if len(loose):
            _, k = cKDTree(V[surf]).query(V[loose])
            W[loose] = W[surf[k]]
    W = _clean(W)
    empty = W.sum(axis=1) == 0                                       # only if the solve broke down numerically
    W[empty] = nearest_share(dist[empty])
    return W


def segment_distances(X, heads, tails):
    """Euclidean distance [N, B] from points X [N, 3] to the segments heads[b] -> tails[b] ([B, 3] each)."""
    return np.linalg.norm(X[:, None, :] - closest_on_segments(X[:, None, :], heads[None], tails[None]), axis=2)


def closest_on_segments(X, heads, tails):
    """Closest points [..., 3] to X on the segments heads -> tails (all [..., 3], broadcast against each
    other); a segment whose ends meet is that point."""
    e = tails - heads
    ee = np.einsum('...j,...j->...', e, e)
    t = np.einsum('...j,...j->...', X - heads, e) / np.where(ee > 0, ee, 1.0)
    return heads + np.clip(t, 0.0, 1.0)[..., None] * e


def nearest_visible_bones(V, F, heads, tails, dist, idx):
    """The nearest bones each vertex of ``idx`` can see.

    V [U, 3], F [F, 3]; heads, tails [B, 3] bone end points; dist [U, B] vertex-bone distances; idx [N]
    vertices (all on faces). Returns (near [N, B] bool: the visible bones within TIE_RATIO of the nearest
    visible one, dmin [N]: the distance to the nearest visible bone, inf where no bone is visible).

    Bones are tried in increasing distance, and a vertex drops out once its next bone is beyond TIE_RATIO x
    its nearest visible one, so only the (vertex, bone) pairs that can matter are ray-tested: 1.05-1.3 rays
    per vertex on the sample and benchmark characters, against one per vertex and bone. libigl's embree
    ``bone_visible`` cannot test a chosen subset (it casts from every vertex to one bone and rebuilds its BVH
    on every call), so all rays go through one AABB tree instead; on the armadillo with 11 bones the two give
    identical visibility, and even there (a crude skeleton leaving 3.8 rays per vertex) this takes 0.55 s
    against 0.73 s for one bone_visible call per bone (173k vertices: 2.5 s against 3.2 s).
    """
    import igl

    # libigl's ray-triangle test rejects a hit whose determinant (~ ray length x twice the triangle's area)
    # is below an absolute 1e-6, so on a small-unit or finely tessellated mesh real occluders are missed.
    # Rays are cast in units of a short edge length, where only near-parallel grazes fall below it.
    lengths = np.linalg.norm(V[F] - V[np.roll(F, 1, axis=1)], axis=2).ravel()
    lengths = lengths[lengths > 0]
    unit = float(np.percentile(lengths, 1)) if len(lengths) else 1.0
    V, heads, tails = V / unit, heads / unit, tails / unit
    tree = igl.AABB()
    tree.init(V, F)
    order = np.argsort(dist[idx], axis=1, kind='stable')
    near = np.zeros((len(idx), len(heads)), bool)
    dmin = np.full(len(idx), np.inf)
    active = np.arange(len(idx))
    for r in range(len(heads)):
        checkpoint()
        cand = order[active, r]
        d = dist[idx[active], cand]
        keep = d <= TIE_RATIO * dmin[active]
        active, cand, d = active[keep], cand[keep], d[keep]
        if len(active) == 0:
            break
        seen = sees_bone(tree, V, F, idx[active], heads[cand], tails[cand])
        hit = active[seen]
        near[hit, cand[seen]] = True
        dmin[hit] = np.minimum(dmin[hit], d[seen])
    return near, dmin


def sees_bone(tree, V, F, verts, heads, tails):
    """Visibility of one bone per vertex, as in the paper: vertex verts[k] sees the bone heads[k] -> tails[k]
    if the segment from its closest point on the bone to the vertex crosses no face before reaching it.

    tree: igl.AABB of (V [U, 3], F [F, 3]); verts [N]; heads, tails [N, 3]. Returns [N] bool. A first hit on
    one of the vertex's own faces counts as visible (the segment reaches the vertex's own surface patch:
    precision noise, not an occluder), as in libigl's bone_visible.
    """
    X = V[verts]
    origin = closest_on_segments(X, heads, tails)
    # A ray that runs exactly through an edge or a vertex of an occluder can slip between its triangles (the
    # test is not watertight), and meshes with aligned rings or grids (mirrored limbs, boxes) do this all
    # the time. Moving the origin sideways by a hair, in a direction no mesh is aligned with, avoids it; the
    # ray still ends at the vertex.
    origin = origin + RAY_NUDGE * _perpendicular(X - origin)
    face, _, _ = tree.intersect_ray_first(V, F, origin, X - origin, 1.0 - 1e-6)
    own = (F[np.maximum(face, 0)] == verts[:, None]).any(axis=1)
    return (face < 0) | own


def _perpendicular(D):
    """Unit vectors [N, 3] perpendicular to the rows of D [N, 3], from a fixed direction of no symmetry."""
    P = np.cross(D, _GENERIC_DIRECTION)
    weak = np.linalg.norm(P, axis=1) < 1e-3 * np.linalg.norm(D, axis=1)
    P[weak] = np.cross(D[weak], _GENERIC_DIRECTION[[1, 2, 0]])
    n = np.linalg.norm(P, axis=1, keepdims=True)
    return np.divide(P, n, out=np.zeros_like(P), where=n > 0)


def _heat_hidden_parts(V, F, surf, dist, near, dmin):
    """Give a heat source to each connected part of the surface that sees no bone at all.

    Such a part (a helmet over the head, a coat layered over the body, an accessory beyond the skeleton's
    reach) would otherwise have no heat, hence no weights and a singular system. Its vertices are heated by
    their Euclidean-nearest bones, ignoring visibility, so it still follows the nearby skeleton smoothly.
    V [U, 3], F [F, 3]; surf [N] the vertices on faces; dist [N, B] their bone distances; near [N, B] and
    dmin [N] as from nearest_visible_bones, updated in place.
    """
    adj = sp.coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, 1, axis=1).ravel())), shape=(len(V), len(V)))
    _, label = connected_components(adj, directed=False)
    label = label[surf]
    lit = np.zeros(label.max() + 1, bool)
    lit[label[np.isfinite(dmin)]] = True
    dark = ~lit[label]
    if dark.any():
        dmin[dark] = dist[dark].min(axis=1)
        near[dark] = dist[dark] <= TIE_RATIO * dmin[dark, None]


def solve_heat(V, F, surf, near, dmin, laplacian=None):
    """Solve (K + M H) w_b = M H p_b for every bone b on the vertices surf [N] (those on faces).

    V [U, 3], F [F, 3]; near [N, B] each vertex's nearest visible bones; dmin [N] the distance to them (inf:
    no heat; every connected part has some heat); laplacian: ``surface_laplacian(V, F)`` if made already.
    Returns W [N, B].
    """
    K, mass = laplacian or surface_laplacian(V, F)
    K, mass = K[surf][:, surf], mass[surf]
    h = np.where(np.isfinite(dmin), mass * HEAT_C / dmin ** 2, 0.0)   # diagonal of M H
    p = near / np.maximum(near.sum(axis=1, keepdims=True), 1)
    return solve_spd(K + sp.diags(h), h[:, None] * p)


def surface_laplacian(V, F):
    """Stiffness matrix K [U, U] (positive semidefinite, = -cotangent Laplacian) and lumped vertex areas
    mass [U] of the surface (V [U, 3], F [F, 3]).

    On a mesh of well-shaped triangles (every |cot| <= COT_LIMIT) this is libigl's cotangent matrix with the
    Voronoi mass: a sum of per-triangle Dirichlet energies, so it is positive semidefinite even across
    non-manifold edges. A zero-area face makes it inf/NaN, and a sliver (an angle near 0 or 180 degrees)
    gives a large positive off-diagonal entry that breaks the maximum principle around it (overshooting,
    negative weights); such meshes use the intrinsic Delaunay Laplacian of robust-laplacian (Sharp & Crane
    2020) instead, which mollifies degenerate faces and has no positive off-diagonal entries. It is not used
    everywhere because it is ~10x slower (armadillo, 43k vertices: 0.87 s against 0.08 s; 173k: 2.9 s
    against 0.3 s) and on clean meshes the weights agree to a mean row-L1 of 3e-4 to 7e-4.
    """
    if np.all(np.abs(face_cotangents(V, F)) <= COT_LIMIT):
        import igl

        K = -igl.cotmatrix(V, F)
        mass = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    else:
        import robust_laplacian

        K, M = robust_laplacian.mesh_laplacian(np.ascontiguousarray(V), np.ascontiguousarray(F))
        mass = M.diagonal()
    return sp.csr_matrix(K), np.asarray(mass, dtype=np.float64).ravel()


def face_cotangents(V, F):
    """Cotangent [F, 3] of each face's angle at each corner (inf or NaN for a zero-area face)."""
    out = np.empty(F.shape)
    with np.errstate(divide='ignore', invalid='ignore'):
        for k in range(3):
            u = V[F[:, (k + 1) % 3]] - V[F[:, k]]
            v = V[F[:, (k + 2) % 3]] - V[F[:, k]]
            out[:, k] = np.einsum('ij,ij->i', u, v) / np.linalg.norm(np.cross(u, v), axis=1)
    return out


def solve_spd(A, B):
    """Solve A X = B for a sparse symmetric positive definite A [N, N] and dense B [N, K]; returns X [N, K].

    SuperLU (scipy's splu) with a minimum-degree ordering of A + A^T and symmetric pivoting: the systems here
    are surface Laplacians of at most HEAT_MAX_VERTICES unknowns (denser surfaces are simplified first), where
    it beats CHOLMOD through cholespy (10k vertices, 23 right-hand sides: 27 ms against 45 ms, same solution to
    1e-11), and it comes with scipy. CHOLMOD's supernodal Cholesky pays off only far beyond that size.
    """
    from scipy.sparse.linalg import splu

    A = sp.csc_matrix(A)
    B = np.ascontiguousarray(B, dtype=np.float64)
    return splu(A, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True}).solve(B)


def nearest_share(dist):
    """Weights [N, B] that give each point to its Euclidean-nearest bones (ties shared) from dist [N, B]."""
    near = dist <= TIE_RATIO * dist.min(axis=1, keepdims=True)
    return near / near.sum(axis=1, keepdims=True)


def _clean(W):
    """Clip negatives, drop weights below WEIGHT_FLOOR and renormalise the rows of W [N, B] to sum to 1.

    Returns a new array (W is not modified), worked on in place: a 1M-face scan's [500k, 23] weights are
    92 MB, and each temporary costs ~0.03 s. A row whose sum is 0 holds only zeros after the clip, so it
    stays all zero without being divided."""
    W = np.nan_to_num(W, nan=0.0, posinf=0.0, neginf=0.0)   # a copy
    np.clip(W, 0.0, None, out=W)
    s = W.sum(axis=1, keepdims=True)
    np.divide(W, s, out=W, where=s > 0)
    W[W < WEIGHT_FLOOR] = 0.0
    s = W.sum(axis=1, keepdims=True)
    np.divide(W, s, out=W, where=s > 0)
    return W
