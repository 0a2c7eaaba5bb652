"""Landmarks read off the mesh itself, for the learned placement: where this body's neck is.

A template learned from realistic bodies puts the neck at about 85 % of the height; a stylised character with
a large head (the glTF samples, most game heroes) has it at 75-78 %, and every trunk joint below scales with it
(hips, chest and shoulders of such a body sit about 10 % lower than a box stretch of a realistic body puts
them). The neck is the one trunk landmark the surface shows plainly: the narrowest place between the chest
and the head. On the body's mid-plane (x = 0, canonical frame: y up), the depth of the deepest point at each
height is the radius profile of the trunk and head; the neck is its most prominent valley in the upper body,
the height where the profile is lowest against the highest points above it (the head) and below it (the
chest). Arms held out or hanging lie off the mid-plane and do not touch it.
"""
from __future__ import annotations

import numpy as np

NECK_BAND = 0.55         # fraction of the height above which a standing body's neck can be
NECK_PROMINENCE = 0.2    # the valley's depth against the lower of its two sides, as a fraction of the widest
NECK_FLOOR = 0.05        # the neck's floor: samples this near the deepest valley's depth (of the widest) count
PROFILE_HEIGHTS = 121    # heights sampled over the band
PROFILE_DEPTHS = 61      # points across the body's depth (z) at each height


def radius_profile(field, band: float = NECK_BAND) -> tuple[np.ndarray, np.ndarray]:
    """(heights [H] as fractions of the body's height, radius [H] in mesh units) of the body's mid-plane from
    ``band`` of its height to its top: the distance to the surface of the deepest point at each height
    (negative where the mid-plane lies outside the body there)."""
    V = field.surface_vertices
    lo, hi = V.min(axis=0), V.max(axis=0)
    height = max(hi[1] - lo[1], 1e-12)
    fractions = np.linspace(band, 1.0, PROFILE_HEIGHTS)
    y = lo[1] + fractions * height
    z = np.linspace(lo[2], hi[2], PROFILE_DEPTHS)
    Y, Z = np.meshgrid(y, z, indexing="ij")
    points = np.column_stack([np.zeros(Y.size), Y.ravel(), Z.ravel()])
    return fractions, field.depth(points).reshape(Y.shape).max(axis=1)


def neck_fraction(field) -> float | None:
    """The neck's height as a fraction of the body's height (feet 0, top 1), or None where no neck stands
    out (a robot's trunk, a hooded cloak, a creature that does not stand upright): the most prominent valley
    of the mid-plane's radius profile (``radius_profile``), its depth at least ``NECK_PROMINENCE`` of the
    widest point's radius."""
    fractions, radius = radius_profile(field)
    widest = radius.max()
    if widest <= 0:
        return None
    below = np.maximum.accumulate(radius)                   # the highest point at or below each height
    above = np.maximum.accumulate(radius[::-1])[::-1]       # ... at or above it
    prominence = np.minimum(below, above) - radius
    best = int(np.argmax(prominence))
    if prominence[best] < NECK_PROMINENCE * widest:
        return None
    # Not the single deepest sample: a neck is often as narrow over a stretch (a low-poly neck is a prism), and
    # which of its samples is deepest by a hair is noise. The valley's floor within NECK_FLOOR of its depth,
    # the run of samples around the deepest, weighted by how far each dips below that level.
    weight = np.maximum(prominence - (prominence[best] - NECK_FLOOR * widest), 0.0)
    run = np.flatnonzero(weight > 0)
    breaks = np.flatnonzero(np.diff(run) > 1)
    starts, ends = np.r_[run[0], run[breaks + 1]], np.r_[run[breaks], run[-1]]
    k = int(np.searchsorted(ends, best))
    sl = slice(starts[k], ends[k] + 1)
    return float(np.average(fractions[sl], weights=weight[sl]))
