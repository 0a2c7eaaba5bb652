"""The hand as a surface of its own: the part of the full-resolution mesh beyond the wrist, and the geodesic
distance over it from the wrist's cut.

The whole body's distance field and sphere graph are far too coarse for fingers (a finger is a few of its
cells wide), so the hand is read off the input's own triangles: the piece of surface past a plane a little
before the wrist, connected to the wrist, within reach of it. A dense hand is simplified to at most
``HAND_MAX_VERTICES`` first; that still leaves each finger hundreds of vertices.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from ..input.facing import edge_graph

CUT_BEFORE_WRIST = 0.25   # the cut plane lies this far (x forearm length) before the wrist, towards the elbow,
                          # so that a wrist placed a little into the palm does not cut the thumb's base off
REACH = 1.5               # the hand lies within this many forearm lengths of the wrist (hands are 0.6-0.8)
HAND_MAX_VERTICES = 8000  # denser hands are simplified to this many vertices before they are read
MIN_VERTICES = 60         # fewer vertices than this beyond the wrist: too coarse to see fingers
HAND_EXTENT = 0.76        # how far the hand reaches past its wrist, x the forearm: the median over the corpus's 48
                          # hands with the artists' wrists (0.70-0.86; benchmarks/hands.py --short 0 prints it)
SHORT_OF_HAND = 0.4       # a limb reaching more than this many forearms farther than that has a wrist short of its
                          # hand: the hands are read right with the artists' wrists moved back up to 0.4 forearms,
                          # not all of them beyond (benchmarks/hands.py --short)
LIMB_REACH = 3.0          # how far past the wrist (x the forearm) a limb that goes on past REACH is followed
# These are set by hand, not tuned: on the corpus (benchmarks/hands.py --fit, leave-one-body-out) the finger
# joints' error is 4.8 / 4.7 / 4.8 % of the hand's length with the cut 0.15 / 0.25 / 0.35 forearms before the
# wrist, and 4.7 % with a reach of 1.2, 1.5 or 2 forearms.


@dataclass
class HandSurface:
    """The hand's surface and its geodesic distance from the wrist cut.

    vertices   [N, 3] the hand's (welded, possibly simplified) vertices, in the rig's frame
    faces      [G, 3] triangles over them
    edges      [N, N] sparse symmetric edge-length graph
    geodesic   [N] distance over the surface from the cut ring (0 on it)
    axis       [3] unit forearm direction, elbow -> wrist
    forearm    forearm length (elbow to wrist)
    piece      the full-resolution piece it was read off (``hand_piece``), which the hand's weights heat
    """
    vertices: np.ndarray
    faces: np.ndarray
    edges: sp.csr_matrix
    geodesic: np.ndarray
    axis: np.ndarray
    forearm: float
    piece: "HandPiece"


@dataclass
class HandPiece:
    """The hand's piece of the welded mesh, at full resolution, before anything is read off it.

    weld      [V] index of each input vertex in the welded mesh (``autorig.weights.attach.weld_surface``)
    ids       [N] welded vertices of the piece (the hand and the end of the forearm, past the cut)
    vertices  [N, 3] their positions; faces [G, 3] the piece's triangles over them
    along     [N] distance of each past the wrist, along the forearm (negative before it)
    ring_reach  how far along the arm the cut's ring of vertices reaches
    """
    weld: np.ndarray
    ids: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    along: np.ndarray
    ring_reach: float


def hand_piece(vertices, faces, wrist, elbow, reach: float = REACH) -> HandPiece | None:
    """The piece of the surface beyond a cut just before the wrist, within ``reach`` forearms of it and joined to
    it; None if it has too few vertices to see fingers. vertices [V, 3], faces [F, 3]: the whole mesh; wrist,
    elbow [3]."""
    from ..weights.attach import weld_surface

    wrist, elbow = np.asarray(wrist, float), np.asarray(elbow, float)
    forearm = float(np.linalg.norm(wrist - elbow))
    if forearm <= 0:
        return None
    axis = (wrist - elbow) / forearm
    weld, V, F = weld_surface(np.asarray(vertices, float), np.asarray(faces, np.int64))
    along = (V - wrist) @ axis
    keep = (along >= -CUT_BEFORE_WRIST * forearm) & (np.linalg.norm(V - wrist, axis=1) <= reach * forearm)
    inside = keep[F].all(axis=1)
    if inside.sum() < MIN_VERTICES:
        return None
    # The cut crosses the arm along a ring of kept vertices with a neighbour before the plane; on a coarse arm
    # that ring is as ragged as its edges are long, so it is found by that, not by a distance from the plane.
    before = along < -CUT_BEFORE_WRIST * forearm
    crossing = (before[F].any(axis=1) & keep[F].any(axis=1))
    ring_reach = float(along[F[crossing]][keep[F[crossing]]].max()) if crossing.any() else -np.inf
    used = np.unique(F[inside])
    local = np.full(len(V), -1)
    local[used] = np.arange(len(used))
    HV, HF = V[used], local[F[inside]]
    # The hand is the piece joined to the wrist: the one whose vertices come nearest the wrist point.
    _, label = connected_components(edge_graph(HV, HF), directed=False)
    piece = label == label[int(np.argmin(np.linalg.norm(HV - wrist, axis=1)))]
    ids = used[piece]
    HV, HF = _subset(HV, HF, piece)
    if len(HV) < MIN_VERTICES:
        return None
    return HandPiece(weld, ids, HV, HF, along[ids], ring_reach)


def hand_surface(vertices, faces, wrist, elbow) -> HandSurface | None:
    """The surface of the hand at the end of the forearm elbow -> wrist, or None if there is none to read
    (too few vertices beyond the wrist).

    vertices [V, 3], faces [F, 3]: the whole mesh (any resolution; welded here); wrist, elbow [3].
    """
    piece = hand_piece(vertices, faces, wrist, elbow)
    if piece is None:
        return None
    wrist, elbow = np.asarray(wrist, float), np.asarray(elbow, float)
    forearm = float(np.linalg.norm(wrist - elbow))
    axis = (wrist - elbow) / forearm
    HV, HF = piece.vertices, piece.faces
    if len(HV) > HAND_MAX_VERTICES:
        HV, HF = _simplified(HV, HF)
    graph = edge_graph(HV, HF)
    # Seeds: the ring where the cut plane crossed the arm (the piece's boundary nearest the cut).
    seeds = _cut_ring(HV, HF, (HV - wrist) @ axis, piece.ring_reach)
    if len(seeds) == 0:
        return None
    geodesic = dijkstra(graph, directed=False, indices=seeds, min_only=True)
    geodesic[~np.isfinite(geodesic)] = 0.0
    return HandSurface(HV, HF, graph, geodesic, axis, forearm, piece)


def hand_extent(piece: HandPiece, wrist, elbow) -> float:
    """How far the surface of ``piece`` (``hand_piece``) reaches past the wrist along the forearm, x the
    forearm's length (elbow -> wrist, [3] each)."""
    return float(piece.along.max()) / float(np.linalg.norm(np.asarray(wrist, float) - np.asarray(elbow, float)))


def short_wrist_shift(vertices, faces, wrist, elbow, piece: HandPiece) -> float:
    """How far (mesh units, along the forearm) to move a wrist that stops short of its hand so that the limb
    reaches HAND_EXTENT forearms (elbow -> wrist as given) past it; 0 for a wrist whose hand (``piece``, from
    ``hand_piece``) reaches no more than HAND_EXTENT + SHORT_OF_HAND forearms past it. vertices [V, 3],
    faces [F, 3]: the whole mesh; wrist, elbow [3]."""
    if hand_extent(piece, wrist, elbow) <= HAND_EXTENT + SHORT_OF_HAND:
        return 0.0
    limb = hand_piece(vertices, faces, wrist, elbow, reach=LIMB_REACH)     # followed on past REACH
    extent = hand_extent(limb if limb is not None else piece, wrist, elbow)
    # In forearms as given: an arm that ends short has its elbow short too (the forearm's length keeps).
    return float(np.linalg.norm(np.asarray(wrist, float) - np.asarray(elbow, float))) * max(extent - HAND_EXTENT, 0.0)


def _cut_ring(V, F, along, ring_reach) -> np.ndarray:
    """Vertices [K] on open edges of the piece (V [N, 3], F [G, 3]) no farther along the arm (along [N]) than
    the cut's ring reaches (``ring_reach``): the piece's other open edges, if any, lie far beyond the wrist."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    boundary = np.unique(uniq[count == 1])
    return boundary[along[boundary] <= ring_reach + 1e-9]


def _subset(V, F, keep) -> tuple[np.ndarray, np.ndarray]:
    """(V', F'): the vertices where keep [N] is True and the faces among them, renumbered."""
    faces = F[keep[F].all(axis=1)]
    used = np.flatnonzero(keep)
    local = np.full(len(V), -1)
    local[used] = np.arange(len(used))
    return V[used], local[faces]


def _simplified(V, F) -> tuple[np.ndarray, np.ndarray]:
    """The hand simplified to about HAND_MAX_VERTICES vertices (fast_simplification, quadric decimation)."""
    import fast_simplification

    sV, sF = fast_simplification.simplify(V, F.astype(np.int32), target_count=2 * HAND_MAX_VERTICES)
    return np.asarray(sV, np.float64), np.asarray(sF, np.int64)
