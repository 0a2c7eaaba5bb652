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
from typing import Protocol

import mcubes
import numpy as np

from ..samples import _Cone, _Ellipsoid, _mesh, _smooth_min, _unit


@dataclass(frozen=True)
class BranchedShape:
    """A closed, manifold, connected mesh around a known branching axis.

    vertices  [V, 3] float64 vertex positions
    faces     [F, 3] int64 triangles, counter-clockwise seen from outside
    tips      [N, 3] float64 the end of each branch's axis: the centre of its rounded cap, inside the surface
              by the cap's radius
    bases     [N, 3] float64 where each branch's axis leaves the body's surface, or None (not a creature)
    straight  [N] bool whether each branch is straight, or None
    """
    vertices: np.ndarray
    faces: np.ndarray
    tips: np.ndarray
    bases: np.ndarray | None = None
    straight: np.ndarray | None = None


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


# ------------------------------------------------------------------------------------------ random creatures

BODIES = ("sphere", "ellipsoid", "capsule", "blob")
LAYOUTS = ("all round", "below", "flat")     # limbs spread over the sphere, over the lower half, around a ring
DEFAULT_VOXELS = 96                          # the extraction's default resolution, which limb radii refer to
THINNEST = 1.5                               # the thinnest limb's radius, voxels at DEFAULT_VOXELS


class Draw(Protocol):
    """A source of random choices: numpy's generator (``NumpyDraw``) or a hypothesis ``draw`` (the tests)."""

    def uniform(self, lo: float, hi: float) -> float: ...

    def integer(self, lo: int, hi: int) -> int: ...      # lo..hi inclusive

    def pick(self, options: tuple) -> object: ...


@dataclass(frozen=True)
class NumpyDraw:
    """``Draw`` from a numpy generator: ``random_creature(NumpyDraw(np.random.default_rng(seed)))``."""
    rng: np.random.Generator

    def uniform(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def integer(self, lo: int, hi: int) -> int:
        return int(self.rng.integers(lo, hi + 1))

    def pick(self, options: tuple) -> object:
        return options[int(self.rng.integers(len(options)))]


@dataclass(frozen=True)
class LimbSpec:
    """One limb: leaves the body along ``direction`` [3] (unit) and reaches ``length`` body radii beyond the
    body's surface; ``radius`` voxels thick (at DEFAULT_VOXELS) where it leaves, ``taper`` times that at its tip
    (never under THINNEST); bent once by ``bend`` degrees (0: straight) about ``bend_axis`` [3] (unit, across
    the limb) at ``bend_at`` of its length."""
    direction: tuple[float, float, float]
    length: float
    radius: float
    taper: float
    bend: float
    bend_axis: tuple[float, float, float]
    bend_at: float


@dataclass(frozen=True)
class CreatureSpec:
    """A body of one of BODIES: semi-axes ``radii`` [3] (a capsule: half its length, then its radius twice),
    turned by the rotation vector ``turn`` [3]; a blob has small balls on its surface in the directions
    ``bumps`` [B, 3]. ``limbs`` leave it; ``welded``: one smooth surface, else overlapping closed parts."""
    body: str
    radii: tuple[float, float, float]
    turn: tuple[float, float, float]
    bumps: tuple[tuple[float, float, float], ...]
    limbs: tuple[LimbSpec, ...]
    welded: bool


def random_creature(draw: Draw, max_limbs: int = 10) -> CreatureSpec:
    """A creature with 1 to ``max_limbs`` limbs, laid out all round, below or flat around the body, as far
    apart as the layout allows and then jittered, so that no two limbs merge into one."""
    body = draw.pick(BODIES)
    radii = (1.0, 1.0, 1.0) if body == "sphere" else (draw.uniform(1.3, 2.0), 1.0, 1.0) if body == "capsule" \
        else (draw.uniform(1.0, 1.6), draw.uniform(0.7, 1.0), draw.uniform(0.6, 1.0))
    turn = (draw.uniform(-np.pi, np.pi), draw.uniform(-np.pi, np.pi), draw.uniform(-np.pi, np.pi))
    bumps = tuple(_random_direction(draw) for _ in range(draw.integer(4, 9) if body == "blob" else 0))
    count = draw.integer(1, max_limbs)
    layout = draw.pick(LAYOUTS)
    spacing = 2 * np.pi / count if layout == "flat" else np.sqrt((2 if layout == "below" else 4) * np.pi / count)
    limbs = []
    for d in _layout_directions(count, str(layout), draw.uniform(0, 2 * np.pi)):
        d = _unit(d + 0.2 * min(spacing, 1.0) * np.array(_random_direction(draw)))
        across = _rotate(_unit(np.cross(d, _least_aligned_axis(d))), d, draw.uniform(0, 2 * np.pi))
        limbs.append(LimbSpec(direction=tuple(d), length=draw.uniform(0.9, 2.4), radius=draw.uniform(THINNEST, 4.5),
                              taper=float(draw.pick((1.0, 0.8, 0.6, 0.45))),
                              bend=draw.uniform(25, 70) if draw.integer(0, 1) else 0.0, bend_axis=tuple(across),
                              bend_at=draw.uniform(0.35, 0.65)))
    return CreatureSpec(str(body), radii, turn, bumps, tuple(limbs), welded=bool(draw.integer(0, 1)))


def creature(spec: CreatureSpec, faces: int = 5000) -> BranchedShape:
    """The mesh of ``spec``, decimated to about ``faces`` triangles; tips: each limb's end, in spec order."""
    import fast_simplification
    from scipy.spatial.transform import Rotation

    axes = Rotation.from_rotvec(spec.turn).as_matrix().T              # rows: the body's own axes
    radii = np.array(spec.radii)
    if spec.body == "capsule":
        half = (radii[0] - radii[1]) * axes[0]
        body: list = [_Cone(-half, half, radii[1], radii[1])]
    else:
        body = [_Ellipsoid(np.zeros(3), radii, axes)]
    body += [_Ellipsoid(0.9 * _surface(body[0], np.array(b)) * np.array(b), np.full(3, 0.3)) for b in spec.bumps]
    # Limb radii are in voxels of the finished creature's longest side: settle that size by a few rounds.
    voxel = 0.0
    for _ in range(4):
        limbs, tips = zip(*[_limb(body[0], limb, voxel) for limb in spec.limbs]) if spec.limbs else ((), ())
        parts = body + [cone for cones in limbs for cone in cones]
        lo = np.min([p.bounds()[0] for p in parts], axis=0)
        hi = np.max([p.bounds()[1] for p in parts], axis=0)
        voxel = float((hi - lo).max()) / DEFAULT_VOXELS
    # Marching-cubes cells a bit finer than the voxels, so the thinnest limbs come out round.
    cell = voxel / 1.3
    meshes = [_union_mesh(parts, 2 * voxel, cell)] if spec.welded else [_union_mesh([p], 0.0, cell) for p in parts]
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    vertices = np.concatenate([v for v, _ in meshes])
    triangles = np.concatenate([f + o for (_, f), o in zip(meshes, offsets)])
    if len(triangles) > faces:
        vertices, triangles = fast_simplification.simplify(vertices, triangles.astype(np.int32),
                                                            target_reduction=1 - faces / len(triangles))
    bases = np.array([_surface(body[0], np.array(limb.direction)) for limb in spec.limbs]).reshape(-1, 3)
    return BranchedShape(np.asarray(vertices, dtype=np.float64), np.asarray(triangles, dtype=np.int64),
                         np.array(tips).reshape(-1, 3), bases, np.array([limb.bend == 0 for limb in spec.limbs]))


@dataclass(frozen=True)
class LimbScore:
    """How a skeleton's chains match a shape's known branches.

    limbs, chains    branches of the shape, chains of the skeleton (``_end`` joints)
    found            branches whose tip has a chain end of its own near it (mutually nearest, within
                     TIP_TOLERANCE of the shape's longest side)
    shortest_bone    the shortest bone over the diagonal of the mesh's box
    start_gap        [found] for each found branch, voxels (DEFAULT_VOXELS along the longest side) from where
                     it leaves the body to the nearest joint of the start of its chain (its first joint or
                     the one it hangs from); empty without ``bases``
    straight_inner   [straight found] inner joints (all but the tip) of each straight branch's chain
    """
    limbs: int
    chains: int
    found: int
    shortest_bone: float
    start_gap: np.ndarray
    straight_inner: np.ndarray

    @property
    def exact(self) -> bool:
        """One chain per branch, and no other."""
        return self.found == self.limbs == self.chains


TIP_TOLERANCE = 0.08


def score_limbs(shape: BranchedShape, names: list[str], parents: np.ndarray, joints: np.ndarray) -> LimbScore:
    """Score a skeleton (joint names, parents [J], joints [J, 3] in the shape's frame) against ``shape``."""
    parents = np.asarray(parents)
    ends = np.array([j for j, n in enumerate(names) if n.endswith("_end")], dtype=np.int64)
    size = float(np.ptp(shape.vertices, axis=0).max())
    diagonal = float(np.linalg.norm(np.ptp(shape.vertices, axis=0)))
    bones = np.linalg.norm(joints[1:] - joints[parents[1:]], axis=1)
    found_ends = {}
    if len(ends) and len(shape.tips):
        gap = np.linalg.norm(shape.tips[:, None] - joints[ends][None], axis=2)        # [tips, ends]
        for t, e in enumerate(gap.argmin(axis=1)):
            if gap[:, e].argmin() == t and gap[t, e] < TIP_TOLERANCE * size:
                found_ends[t] = int(ends[e])
    starts, inner = [], []
    for t, end in found_ends.items():
        chain = names[end].split("_")[0]
        members = [j for j, n in enumerate(names) if n.split("_")[0] == chain]
        first = min(members)
        if shape.bases is not None:
            near = joints[[first, parents[first]]]
            starts.append(float(np.linalg.norm(near - shape.bases[t], axis=1).min()) / size * DEFAULT_VOXELS)
        if shape.straight is not None and shape.straight[t]:
            inner.append(len(members) - 1)
    return LimbScore(len(shape.tips), len(ends), len(found_ends), float(bones.min() / diagonal) if len(bones) else 0.0,
                     np.array(starts), np.array(inner, dtype=np.int64))


def _limb(body, limb: LimbSpec, voxel: float) -> tuple[list, np.ndarray]:
    """The cones [1 or 2] of ``limb`` on ``body`` (voxel: the creature's voxel size; 0 to guess) and its tip [3].
    The limb starts halfway into the body, so that it is rooted in it."""
    d = np.array(limb.direction)
    start = _surface(body, d)
    r_base = limb.radius * (voxel or 0.02)
    r_tip = max(limb.radius * limb.taper, THINNEST) * (voxel or 0.02)
    end_straight = start + limb.length * d
    if not limb.bend:
        return [_Cone(0.5 * start, end_straight, r_base, r_tip)], end_straight
    elbow = start + limb.bend_at * limb.length * d
    r_elbow = r_base + limb.bend_at * (r_tip - r_base)
    tip = elbow + (1 - limb.bend_at) * limb.length * _rotate(d, np.array(limb.bend_axis), np.radians(limb.bend))
    return [_Cone(0.5 * start, elbow, r_base, r_elbow), _Cone(elbow, tip, r_elbow, r_tip)], tip


def _surface(part, direction: np.ndarray) -> np.ndarray:
    """Where the ray from the origin along the unit direction [3] leaves part (a convex solid around it)."""
    lo, hi = 0.0, 10.0
    for _ in range(40):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if part.distance(mid * direction[None])[0] < 0 else (lo, mid)
    return lo * direction


def _random_direction(draw: Draw) -> tuple[float, float, float]:
    """A unit vector [3] spread evenly over the sphere."""
    y, angle = draw.uniform(-1.0, 1.0), draw.uniform(0.0, 2 * np.pi)
    ring = np.sqrt(1 - y * y)
    return (float(ring * np.cos(angle)), y, float(ring * np.sin(angle)))


def _layout_directions(n: int, layout: str, spin: float) -> np.ndarray:
    """n unit vectors [n, 3]: spread over the sphere, over its lower half (legs under a body), or round the
    horizontal ring (a star lying flat); turned by ``spin`` about the vertical."""
    if layout == "flat":
        angle = spin + 2 * np.pi * np.arange(n) / n
        return np.stack([np.cos(angle), np.zeros(n), np.sin(angle)], axis=1)
    k = np.arange(n) + 0.5
    y = -k / n if layout == "below" else 1.0 - 2.0 * k / n
    ring = np.sqrt(1.0 - y * y)
    angle = spin + np.pi * (3.0 - np.sqrt(5.0)) * k
    return np.stack([ring * np.cos(angle), y, ring * np.sin(angle)], axis=1)


def _union_mesh(parts: list, blend: float, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices [V, 3] and faces [F, 3] of the smooth union of ``parts`` (as ``samples._mesh``, marching cubes
    on cells of edge ``cell``), each part's distance evaluated only in its own box grown by the blend and two
    cells: further out it cannot change the surface, and a creature's thin limbs fill little of its box."""
    lo = np.min([p.bounds()[0] for p in parts], axis=0) - 3 * cell
    counts = np.ceil((np.max([p.bounds()[1] for p in parts], axis=0) + 3 * cell - lo) / cell).astype(int) + 1
    sdf = np.full(tuple(counts), np.inf)
    margin = blend + 2 * cell
    for p in parts:
        a = np.maximum(np.floor((p.bounds()[0] - margin - lo) / cell).astype(int), 0)
        b = np.minimum(np.ceil((p.bounds()[1] + margin - lo) / cell).astype(int) + 1, counts)
        axes = [lo[k] + cell * np.arange(a[k], b[k]) for k in range(3)]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        box = (slice(a[0], b[0]), slice(a[1], b[1]), slice(a[2], b[2]))
        distance = p.distance(points).reshape(b - a)
        sdf[box] = np.minimum(sdf[box], distance) if blend == 0 else _smooth_min(sdf[box], distance, blend)
    sdf = np.minimum(sdf, 2 * margin)                    # far from every part: outside, finite for mcubes
    # As in samples._mesh: keep samples off the level set (no sliver triangles); mcubes winds outward here.
    inside = np.where(np.abs(sdf) < 0.1 * cell, np.copysign(0.1 * cell, -sdf), -sdf)
    vertices, faces = mcubes.marching_cubes(inside, 0.0)
    return lo + vertices * cell, faces.astype(np.int64)
