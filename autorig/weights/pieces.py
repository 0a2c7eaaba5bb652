"""Separate pieces follow the body part they sit on or in: eyes, teeth, nails, buttons, belts, hair, props.

Bone heat (``autorig.attach``) diffuses over the surface, so a piece not connected to the body (a fingernail,
an eye in its socket, a row of teeth, a hair card) is heated only by the bones it happens to see, which may be
far from the body part it belongs to: a nail that sees the upper arm through the gap between the fingers goes
with the shoulder. The rule here, from geometry alone, so that it holds on scans, game assets and hand-made
meshes alike:

* the **body** is the connected part of the largest area; a part larger than ``SMALL`` of the height that
  mostly lies away from it (its median distance to the body over ``LAYER`` of the height: a separate head,
  an arm modelled apart, a spear), and a part that a bone runs through (a hand modelled apart, a ring round a
  finger), keep their own heat and count as body too;
* a **small** piece (bounding-box diagonal at most ``SMALL`` of the height: a tooth, a nail, an eye, a button)
  is rigid: every vertex takes one row, the mean of the body's weights at the closest body points of the
  piece's vertices that touch the body (within ``CONTACT`` of the piece's size of its closest vertex), so a
  nail follows the fingertip it lies on and a sword its grip's hand;
* a **large** piece that lies along the body (a sleeve, a skirt, a belt, a layer of clothes, long hair) is
  smooth: each vertex takes the body's weights at its closest body point.

The height is the bounding box's longest side unless the caller knows better (the prepared mesh is one unit
tall).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..input.facing import unique_ints

SMALL = 0.1      # pieces no larger than this fraction of the height move rigidly
LAYER = 0.04     # a larger piece whose median distance to the body is below this fraction of the height is
                 # a layer over it (clothes, hair) and takes the body's weights; farther, it keeps its own
CONTACT = 0.25   # a rigid piece's vertices within this fraction of its size of its closest one touch the body


def follow_body(V, F, W, height: float | None = None, bones=None) -> np.ndarray:
    """Weights [U, K] with the separate pieces' rows taken from the body (see the module docstring).

    V [U, 3] welded vertices, F [G, 3] faces on them (no repeated corners), W [U, K] weights (rows >= 0 summing
    to 1; bones or joints alike); height: the character's height in V's units (None: the longest side of the
    bounding box); bones: optional (heads [B, 3], tails [B, 3]): a small piece that a bone runs through (the
    middle of a bone inside its bounding box: a hand or a head modelled apart, a ring round a finger) keeps its
    own weights and counts as body. Vertices on no face keep their rows. A mesh of one piece is returned as it
    is."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if len(F) == 0:
        return W
    n = len(V)
    adj = sp.coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, 1, axis=1).ravel())), shape=(n, n))
    count, label = connected_components(adj, directed=False)
    on_face = np.zeros(n, bool)
    on_face[F.ravel()] = True
    parts = unique_ints(label[on_face])
    if len(parts) < 2:
        return W
    height = float(height) if height else float(np.ptp(V[on_face], axis=0).max())
    area = np.zeros(count)
    np.add.at(area, label[F[:, 0]], 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                                         axis=1))
    body = int(parts[np.argmax(area[parts])])
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, label[on_face], V[on_face])
    np.maximum.at(hi, label[on_face], V[on_face])
    size = np.linalg.norm(np.where(np.isfinite(hi - lo), hi - lo, 0.0), axis=1)

    anchor = np.zeros(count, bool)
    anchor[body] = True
    if bones is not None and len(bones[0]):
        heads, tails = (np.asarray(b, dtype=np.float64).reshape(-1, 3) for b in bones)
        middle = np.vstack([heads + s * (tails - heads) for s in (0.25, 0.5, 0.75)])      # [3B, 3]
        for p in parts:            # a few to thousands of pieces (hair cards), each against every bone's middle
            anchor[p] |= bool(np.all((middle >= lo[p]) & (middle <= hi[p]), axis=1).any())
    large = [int(p) for p in parts if p != body and size[p] > SMALL * height]
    if large:
        idx = np.flatnonzero(np.isin(label, large) & on_face)
        dist, _, _ = closest_points(V, F, label == body, V[idx])
        for p in large:
            if np.median(dist[label[idx] == p]) > LAYER * height:
                anchor[p] = True
    moved = on_face & ~anchor[label]
    if not moved.any():
        return W
    idx = np.flatnonzero(moved)
    dist, corners, bary = closest_points(V, F, anchor[label], V[idx])
    at = np.einsum("nk,nkj->nj", bary, np.asarray(W)[corners])          # body weights at the closest points
    out = np.array(W, dtype=np.float64, copy=True)
    out[idx] = at
    small = np.flatnonzero(size <= SMALL * height)
    rigid = np.isin(label[idx], small)
    if rigid.any():
        pieces = label[idx[rigid]]
        closest = np.full(count, np.inf)
        np.minimum.at(closest, pieces, dist[rigid])
        touch = dist[rigid] <= closest[pieces] + CONTACT * size[pieces]
        total = np.zeros((count, out.shape[1]))
        np.add.at(total, pieces[touch], at[rigid][touch])
        total /= np.maximum(total.sum(axis=1, keepdims=True), 1e-300)
        out[idx[rigid]] = total[pieces]
    return out


def closest_points(V, F, keep, X):
    """(distance [N], corners [N, 3], barycentric coordinates [N, 3]) of the closest points to X [N, 3] on the
    faces of V [U, 3], F [G, 3] whose corners are all ``keep`` [U] bool."""
    import igl

    faces = F[keep[F].all(axis=1)]
    d2, face, closest = igl.point_mesh_squared_distance(np.ascontiguousarray(X), V, faces)
    corners = faces[np.asarray(face, dtype=np.int64)]
    bary = igl.barycentric_coordinates(closest, V[corners[:, 0]], V[corners[:, 1]], V[corners[:, 2]])
    bary = np.clip(np.nan_to_num(bary, nan=1.0 / 3.0), 0.0, None)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), 1e-300)
    return np.sqrt(np.maximum(d2, 0.0)), corners, bary
