"""Procedural shapes with known branches: test fixtures for the template-free skeleton.

    from autorig.extract.shapes import star, tree
    s = star(arms=6)
    s.vertices, s.faces, s.tips          # tips: where each branch's axis ends, one per branch

Built like the characters of ``autorig.samples``: a smooth union of tapered capsules (and a ball) laid along a
known branching axis, meshed with marching cubes. Every branch ends in a rounded cap whose centre is in
``tips``, so a skeleton extracted from the shape should have exactly one chain ending near each of them.

Frame: +y up; sizes are arbitrary units (autorig rescales every mesh to unit height).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..samples import _Cone, _Ellipsoid, _mesh, _unit


@dataclass(frozen=True)
class BranchedShape:
    """A closed, manifold, connected mesh around a known branching axis.

    vertices  [V, 3] float64 vertex positions
    faces     [F, 3] int64 triangles, counter-clockwise seen from outside
    tips      [N, 3] float64 the end of each branch's axis: the centre of its rounded cap, inside the surface
              by the cap's radius
    """
    vertices: np.ndarray
    faces: np.ndarray
    tips: np.ndarray


def star(arms: int = 5, resolution: int = 64) -> BranchedShape:
    """A ball with ``arms`` (>= 2) tapering arms spread evenly over the sphere of directions, each bent once
    by 35 degrees at 55% of its length, arm lengths varying by up to 20%; ``resolution`` grid cells along the
    longest side."""
    if arms < 2:
        raise ValueError(f"a star needs at least 2 arms, got {arms}")
    shapes: list = [_Ellipsoid(np.zeros(3), np.full(3, 0.25))]
    tips = []
    for k, direction in enumerate(_spread_directions(arms)):
        length = 1.0 + 0.1 * ((k % 3) - 1) * 2
        elbow = 0.55 * length * direction
        bent = _rotate(direction, _unit(np.cross(direction, _least_aligned_axis(direction))), np.radians(35))
        tip = elbow + 0.45 * length * bent
        r_base, r_elbow, r_tip = 0.09, 0.07, 0.045
        shapes += [_Cone(np.zeros(3), elbow, r_base, r_elbow), _Cone(elbow, tip, r_elbow, r_tip)]
        tips.append(tip)
    vertices, faces = _mesh(shapes, blend=0.04, resolution=resolution)
    return BranchedShape(vertices, faces, np.array(tips))


def tree(levels: int = 2, resolution: int = 64) -> BranchedShape:
    """A trunk standing on +y that forks in two ``levels`` (>= 1) times, each fork turned a quarter turn about
    its parent from the one before (as real branches alternate), so it has 2**levels twigs. The trunk is evenly
    thick, so its middle is the most central part and its foot is a branch too: the tips are the foot of the
    trunk first, then the twigs' ends. ``resolution``: grid cells along the longest side."""
    if levels < 1:
        raise ValueError(f"a tree needs at least 1 level of forks, got {levels}")
    foot, top = np.array([0.0, 0.1, 0.0]), np.array([0.0, 0.7, 0.0])
    radius = 0.085
    shapes: list = [_Cone(foot, top, radius, radius)]
    tips = [foot]
    # (start, direction, length, radius, fork plane normal) of each branch still to fork
    growing = [(top, np.array([0.0, 1.0, 0.0]), 0.55, radius, np.array([0.0, 0.0, 1.0]))]
    for _ in range(levels):
        grown = []
        for start, direction, length, r_start, normal in growing:
            for side in (1.0, -1.0):
                d = _rotate(direction, normal, side * np.radians(35))
                end = start + length * d
                r_end = 0.7 * r_start
                shapes.append(_Cone(start, end, r_start, r_end))
                grown.append((end, d, 0.75 * length, r_end, _unit(np.cross(d, normal))))
        growing = grown
    tips += [end for end, _, _, _, _ in growing]
    vertices, faces = _mesh(shapes, blend=0.03, resolution=resolution)
    return BranchedShape(vertices, faces, np.array(tips))


def _spread_directions(n: int) -> np.ndarray:
    """n unit vectors [n, 3] spread nearly evenly over the sphere (the Fibonacci spiral)."""
    k = np.arange(n) + 0.5
    y = 1.0 - 2.0 * k / n
    ring = np.sqrt(1.0 - y * y)
    angle = np.pi * (3.0 - np.sqrt(5.0)) * k
    return np.stack([ring * np.cos(angle), y, ring * np.sin(angle)], axis=1)


def _least_aligned_axis(v: np.ndarray) -> np.ndarray:
    """The coordinate axis [3] most nearly perpendicular to v [3]."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(v)))] = 1.0
    return axis


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """v [3] turned by angle (radians) about the unit axis [3] (Rodrigues)."""
    return v * np.cos(angle) + np.cross(axis, v) * np.sin(angle) + axis * (axis @ v) * (1.0 - np.cos(angle))
