"""Automatic orientation: which input axis is up and which way the character faces.

Files come Y-up or Z-up, facing any axis. Two cues decide:

1. Bilateral symmetry. A character is its own mirror image across its mid-plane, whose normal is the
   left-right axis. Of the three coordinate axes, the one whose mirror image of the surface lies closest to
   the surface itself is taken as left-right.
2. The template. The other two axes leave eight frames (up is one of them, either sign; front is the other,
   either sign). The discretization is done once, coarsely, in a neutral frame; its sphere graph is carried
   into each candidate frame and the template embedded there. Feet low, head up, limbs the right way round:
   the frame whose embedding costs least wins, and the gap to the runner-up says how sure that is.

The embedding tells up from down very surely (every character tried so far), and a biped's front from its back
(toes and knees point forward) with a clear gap; a four-legged animal's head from its tail much less so. So the
glTF convention (+y up, facing +z) is preferred by a fixed handicap on every other frame: it is kept unless
the shape clearly says otherwise.

Explicit ``--up`` / ``--front`` always win; only the axes given as ``auto`` are searched.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

AXES = ("x", "y", "z")
SYMMETRY_AMBIGUITY = 1.25  # a second axis this close in mirror error is tried as left-right too
CONVENTION_BONUS = 0.3   # embedding penalty a frame other than +y up / +z front must beat the convention by


@dataclass
class Orientation:
    """up, front: the chosen axis specs ('y', '-z', ...); costs {'up/front': embedding penalty, plus the
    handicap of leaving the glTF convention} of every candidate tried; margin the runner-up's penalty minus the winner's (0 when nothing was searched);
    symmetry [3] mirror error of each input axis (fraction of the size; the smallest is left-right)."""
    up: str
    front: str
    costs: dict[str, float] = field(default_factory=dict)
    margin: float = 0.0
    symmetry: list[float] = field(default_factory=list)


def mirror_errors(vertices: np.ndarray, faces: np.ndarray, samples: int = 2000) -> np.ndarray:
    """[3] how far the mirror image of the surface lies from the surface, mirrored across the plane through
    the bounding-box centre normal to x, y and z in turn (mean distance / bounding-box diagonal)."""
    from .distance import SurfaceQuery
    surface = SurfaceQuery(vertices, faces)
    step = max(1, len(vertices) // samples)
    points = vertices[::step]
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    out = np.zeros(3)
    for axis in range(3):
        mirrored = points.copy()
        mirrored[:, axis] = 2 * centre[axis] - mirrored[:, axis]
        depth, _ = surface.closest(mirrored)
        out[axis] = float(np.mean(np.abs(depth))) / diagonal
    return out


def candidate_frames(up: str, front: str, left_axis: int) -> list[tuple[str, str]]:
    """The (up, front) pairs to try, given the user's specs ('auto' or an axis) and the left-right axis:
    up and front are never the left-right axis, nor each other."""
    def both_signs(axis: int) -> list[str]:
        return [AXES[axis], "-" + AXES[axis]]

    others = [a for a in range(3) if a != left_axis]
    ups = both_signs(others[0]) + both_signs(others[1]) if up == "auto" else [up]
    out = []
    for u in ups:
        u_axis = AXES.index(u[-1])
        if front != "auto":
            fronts = [front] if AXES.index(front[-1]) != u_axis else []
        else:
            fronts = both_signs(next(a for a in range(3) if a not in (u_axis, left_axis)))
        out.extend((u, f) for f in fronts)
    return out


def detect_orientation(vertices: np.ndarray, faces: np.ndarray, template, up: str = "auto",
                       front: str = "auto") -> Orientation:
    """Choose the axes given as 'auto' (see the module docstring). ``vertices`` [V, 3], ``faces`` [F, 3]: the
    mesh as loaded (any units, any orientation); ``template`` the Template to be embedded."""
    from .distance import distance_field
    from .embed.penalties import build_problem
    from .embed.search import search
    from .errors import RigFailedError
    from .graph import sphere_graph
    from .medial import medial_samples, pack_spheres
    from .mesh import frame_rotation, prepare

    if up != "auto" and front != "auto":
        return Orientation(up, front)
    symmetry = mirror_errors(np.asarray(vertices, float), np.asarray(faces, np.int64))
    # A posed character (a galloping horse) can be nearly as symmetric across a second axis: then both are
    # tried as left-right. The user's up is never left-right (trust a character lying on its side).
    order = [a for a in np.argsort(symmetry, kind="stable") if up == "auto" or a != AXES.index(up[-1])]
    left_axes = [a for a in order[:2] if symmetry[a] <= SYMMETRY_AMBIGUITY * symmetry[order[0]] + 1e-4]
    candidates = list(dict.fromkeys(c for a in left_axes for c in candidate_frames(up, front, int(a))))

    # One coarse discretization in a neutral frame (the input's own axes, one unit across).
    neutral = prepare(vertices, faces, up="y", front="z")
    field = distance_field(neutral.work_vertices, neutral.work_faces, max_level=6, tolerance=0.004)
    graph = sphere_graph(field, pack_spheres(medial_samples(field)))
    centers_input = neutral.from_canonical(graph.centers)
    costs = {}
    for u, f in candidates:
        rotation = frame_rotation(u, f)
        rotated = np.asarray(vertices, float) @ rotation.T
        height = float(np.ptp(rotated[:, 1]))
        lo = rotated.min(axis=0)
        hi = rotated.max(axis=0)
        centre = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
        scale = 1.0 / height
        moved = graph.moved((centers_input @ rotation.T - centre) * scale, scale / neutral.scale)
        try:
            cost = float(search(build_problem(moved, template), max_expansions=2000).cost)
        except RigFailedError:
            cost = float("inf")
        costs[f"{u}/{f}"] = cost + CONVENTION_BONUS * ((u.lstrip("+") != "y") + (f.lstrip("+") != "z"))
    ranked = sorted(costs, key=lambda k: (costs[k], k))
    best = ranked[0]
    margin = costs[ranked[1]] - costs[best] if len(ranked) > 1 else 0.0
    u, f = best.split("/")
    return Orientation(u, f, costs, float(margin), [float(s) for s in symmetry])
