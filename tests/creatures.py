"""Random creatures with known limbs as a hypothesis strategy, for the template-free skeleton's tests.

    @given(spec=creatures())
    def test_...(spec):
        shape = creature(spec)          # autorig.extract.shapes: vertices, faces, tips, bases, straight

The distribution itself is ``autorig.extract.shapes.random_creature``, which the benchmark
(``benchmarks/extract_stages.py``) draws from numpy seeds; here hypothesis makes the draws.
"""
from __future__ import annotations

from hypothesis import strategies as st

from autorig.extract.shapes import CreatureSpec, random_creature


class HypothesisDraw:
    """``autorig.extract.shapes.Draw`` from a hypothesis ``draw``."""

    def __init__(self, draw):
        self.draw = draw

    def uniform(self, lo: float, hi: float) -> float:
        return self.draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def integer(self, lo: int, hi: int) -> int:
        return self.draw(st.integers(lo, hi))

    def pick(self, options: tuple) -> object:
        return self.draw(st.sampled_from(options))


@st.composite
def creatures(draw, max_limbs: int = 10) -> CreatureSpec:
    """A random creature: a sphere, ellipsoid, capsule or bumpy blob body with 1 to ``max_limbs`` limbs."""
    return random_creature(HypothesisDraw(draw), max_limbs)
