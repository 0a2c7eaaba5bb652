"""Three joints and a tip per digit, placed along the digit's centreline.

A digit's joints are at fixed fractions of a path that runs from the wrist to the digit's base (the saddle
where it parts from the hand: the web between the fingers) and then along the digit's centreline to its tip.
A fraction u in [0, 1] is the point u of the way along the free digit (``digits.centreline``); u in [-1, 0)
lies on the straight line from the base back to the wrist, -u of the way, where the metacarpals run (the
knuckles of the fingers, both base joints of the thumb). The fractions were measured on MakeHuman's Mixamo
rig over the whole corpus (``python benchmarks/hands.py --fit``: 24 bodies, 48 hands, each fraction the one of
least mean error over all of them), not on any one character.
"""
from __future__ import annotations

import numpy as np

from .digits import FINGERS, Digit, HandReading, centreline
from .region import HandSurface

# u of joints 1, 2, 3 of each digit (see the module's docstring); benchmarks/hands.py --fit prints them.
FRACTIONS = {
    "thumb": (-0.56, -0.28, 0.33),
    "index": (-0.13, 0.17, 0.54),
    "middle": (-0.14, 0.21, 0.65),
    "ring": (-0.16, 0.21, 0.54),
    "pinky": (-0.15, 0.09, 0.50),
}


def along_digit(surface: HandSurface, digit: Digit, wrist, u: float) -> np.ndarray:
    """Point [3] at fraction u in [-1, 1] of the wrist -> base -> tip path of ``digit`` (module docstring)."""
    base = centreline(surface, digit, 0.0)
    if u >= 0:
        return centreline(surface, digit, u)
    return base + (-u) * (np.asarray(wrist, float) - base)


def digit_joints(surface: HandSurface, reading: HandReading, wrist) -> dict[str, np.ndarray]:
    """{finger: [4, 3]} joints 1, 2, 3 and the tip of each digit of a hand read as "fingers"."""
    out = {}
    for name, digit in zip(FINGERS, reading.digits):
        out[name] = np.array([along_digit(surface, digit, wrist, u) for u in FRACTIONS[name]] + [digit.tip])
    return out
