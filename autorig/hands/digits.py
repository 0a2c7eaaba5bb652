"""The digits of a hand: its fingertips as the prominent extremities of the geodesic distance from the wrist,
each finger as the surface beyond the saddle where it parts from its neighbour, and which one is the thumb.

The fingertips are the maxima of the distance over the surface from the wrist cut, and a finger is a maximum
that stands out: the persistence of a maximum (its height above the saddle where its region of the surface
meets one with a higher maximum, 0-dimensional persistent homology of the super-level sets) is the free
length of the finger, while the bumps of knuckles, nails and coarse triangles persist little. A hand with
five prominent extremities has fingers; a mitten has one (two with a thumb), a fist none that stand out.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import connected_components

from .names import FINGERS
from .region import HandSurface

MIN_PERSISTENCE = 0.07    # a fingertip stands at least this far (x the hand's geodesic reach) above the
MIN_TIP_REACH = 0.4       # saddle where its finger meets the next one, and lies at least MIN_TIP_REACH of the
                          # reach from the wrist's cut. On the corpus's 48 hands (GT wrists, benchmarks/hands.py
                          # --fit prints these) every fingertip lies 0.60 or more from the cut and stands 0.16 or
                          # more, bumps by the wrist (ulna, tendons) lie 0.26 or less, and the other bumps stand
                          # 0.034 or less: 0.07 is about the geometric mean of 0.16 and 0.034, 0.4 the middle
                          # of 0.26 and 0.60
RING_BAND = 0.06          # half-width (x the finger's free length) of the band whose centroid is a centreline
                          # point; hand-set (0.04 / 0.06 / 0.09: 5.0 / 4.7 / 4.4 % joint error on the corpus)


@dataclass
class Digit:
    """One finger (or the thumb) of a hand.

    tip       [3] the fingertip: the surface point farthest from the wrist along the finger
    base      geodesic distance from the wrist of the saddle where the finger parts from the hand
    length    its free length: geodesic tip distance - base
    vertices  [K] indices into the hand surface's vertices of the finger's skin beyond the saddle
    persistence  how far its tip stands out (x the hand's geodesic reach)
    """
    tip: np.ndarray
    base: float
    length: float
    vertices: np.ndarray
    persistence: float


@dataclass
class HandReading:
    """What the mesh says of a hand: ``status`` "fingers" (then ``digits`` holds thumb, index, middle, ring,
    pinky in that order), "mitten" (one or two prominent extremities), "fist" (none beyond the palm's reach)
    or "unclear" (3, 4 or more than 5). palm_normal [3]: unit, out of the palm (None without fingers)."""
    status: str
    digits: list[Digit]
    palm_normal: np.ndarray | None
    extremities: int


def read_hand(surface: HandSurface, side: str) -> HandReading:
    """The digits of ``surface`` (``autorig.hands.region.hand_surface``) of the ``side`` ("left"/"right")."""
    f = surface.geodesic
    reach = float(f.max())
    tips, bases, persistence = _prominent_maxima(surface, MIN_PERSISTENCE * reach)
    n = len(tips)
    if n != 5:
        status = "mitten" if n in (1, 2) else "fist" if n == 0 else "unclear"
        return HandReading(status, [], None, n)
    digits = []
    for tip, base, pers in zip(tips, bases, persistence):
        region = _region_beyond(surface, tip, base)
        digits.append(Digit(surface.vertices[tip], base, float(f[tip] - base), region, pers / reach))
    order = _thumb_first(surface, digits)
    digits = [digits[k] for k in order]
    return HandReading("fingers", digits, _palm_normal(surface, digits, side), n)


def _prominent_maxima(surface: HandSurface, threshold: float):
    """(tips [K] vertex indices, bases [K] saddle levels, persistence [K]) of the maxima of the geodesic
    distance that persist at least ``threshold``, the global maximum first (infinite persistence; its base is
    the highest saddle where it meets another prominent maximum)."""
    f = surface.geodesic
    g = surface.edges
    order = np.argsort(-f, kind="stable")
    parent = np.full(len(f), -1)            # union-find over processed vertices; -1: not yet processed

    def find(x):
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    death = {}                              # tip vertex -> level where it died
    merges = []                             # (level, elder tip, younger tip)
    for v in order:
        parent[v] = v
        roots = {find(u) for u in g.indices[g.indptr[v]:g.indptr[v + 1]] if parent[u] >= 0}
        if not roots:
            continue
        roots = sorted(roots, key=lambda r: -f[r])
        elder = roots[0]
        for r in roots[1:]:
            death[r] = f[v]
            merges.append((f[v], elder, r))
            parent[r] = elder
        parent[v] = elder
    top = int(order[0])
    pers = {t: f[t] - d for t, d in death.items()}
    pers[top] = np.inf
    far = MIN_TIP_REACH * f[top]
    tips = [t for t in sorted(pers, key=lambda t: -pers[t]) if pers[t] >= threshold and f[t] >= far]
    base = {t: death.get(t, -np.inf) for t in tips}
    prominent = set(tips)
    for level, elder, younger in merges:
        if elder in prominent and younger in prominent:
            base[elder] = max(base[elder], level)
    return tips, [float(base[t]) for t in tips], [float(f[t] - base[t] if t == top else pers[t]) for t in tips]


def _region_beyond(surface: HandSurface, tip: int, base: float) -> np.ndarray:
    """Vertices [K] of the piece of {geodesic > base} that holds ``tip``."""
    above = np.flatnonzero(surface.geodesic > base)
    sub = surface.edges[above][:, above]
    _, label = connected_components(sub, directed=False)
    return above[label == label[np.searchsorted(above, tip)]]


def _thumb_first(surface: HandSurface, digits: list[Digit]) -> list[int]:
    """Order [5] of ``digits`` as thumb, index, middle, ring, pinky.

    The thumb is the digit that parts from the hand nearest the wrist (the lowest saddle), whose base stands
    apart from the other four's, and that points away from them (opposed); the three cues are added unweighted,
    each in units of the hand's reach or as 1 - cosine. On the corpus's 48 hands (GT wrists) each cue alone
    misses 0-5 thumbs; their sum none, with a margin of 0.19. The four fingers' bases lie on a line across the
    hand (their principal direction); they follow along it from the thumb's side."""
    near_base = np.array([centreline(surface, d, 0.2) for d in digits])
    apart = np.array([np.mean([np.linalg.norm(near_base[i] - near_base[j]) for j in range(5) if j != i])
                      for i in range(5)])
    bases = np.array([d.base for d in digits])
    reach = float(surface.geodesic.max())
    pointing = np.array([d.tip for d in digits]) - near_base
    pointing /= np.maximum(np.linalg.norm(pointing, axis=1, keepdims=True), 1e-12)
    others = np.array([pointing[[j for j in range(5) if j != i]].mean(axis=0) for i in range(5)])
    others /= np.maximum(np.linalg.norm(others, axis=1, keepdims=True), 1e-12)
    opposed = 1.0 - np.einsum("ij,ij->i", pointing, others)
    thumb = int(np.argmax((apart - bases) / reach + opposed))
    rest = [k for k in range(5) if k != thumb]
    points = near_base[rest]
    centred = points - points.mean(axis=0)
    across = np.linalg.svd(centred, full_matrices=False)[2][0]
    if (near_base[thumb] - points.mean(axis=0)) @ across > 0:
        across = -across
    return [thumb, *(rest[k] for k in np.argsort(centred @ across, kind="stable"))]


def _palm_normal(surface: HandSurface, digits: list[Digit], side: str) -> np.ndarray:
    """Unit normal [3] out of the palm: across the hand (index to pinky) and along it (wrist to the middle
    finger's base), oriented by which hand it is."""
    along = centreline(surface, digits[2], 0.0) - surface.vertices[np.argmin(surface.geodesic)]
    across = centreline(surface, digits[1], 0.0) - centreline(surface, digits[4], 0.0)
    n = np.cross(along, across)
    n = n if side == "left" else -n
    return n / (np.linalg.norm(n) or 1.0)


def centreline(surface: HandSurface, digit: Digit, t: float) -> np.ndarray:
    """Point [3] on the digit's centreline at fraction t of its free length from its base (0) to its tip (1):
    the centroid of its skin at that geodesic distance from the wrist, a cross-section's centre."""
    f = surface.geodesic[digit.vertices]
    s = (f - digit.base) / max(digit.length, 1e-12)
    t = float(np.clip(t, 0.0, 1.0))
    band = np.abs(s - t) <= RING_BAND
    if not band.any():
        band = np.abs(s - t) <= np.abs(s - t).min() + 1e-12
    return surface.vertices[digit.vertices[band]].mean(axis=0)
