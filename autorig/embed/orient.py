"""Automatic orientation: which input axis is up and which way the character faces.

Files come Y-up or Z-up, facing any axis. These decide:

1. Bilateral symmetry. A character is its own mirror image across its mid-plane, whose normal is the
   left-right axis. Of the three coordinate axes, the one whose mirror image of the surface lies closest to
   the surface itself is taken as left-right, and so is the one most nearly symmetric across its own best
   plane (``mirror_plane``), since a spear held forward or a shield to one side moves the box's centre.
2. The template. The other two axes leave eight frames (up is one of them, either sign; front is the other,
   either sign). The discretization, done once in the input's own axes, is carried into each candidate
   frame (a rotation and a scale) and the template embedded there. Feet low, head up, limbs the right way round:
   the frame whose embedding costs least wins, and the gap to the runner-up says how sure that is.

The embedding tells up from down very surely (every character tried so far), and a biped's front from its back
(toes and knees point forward) by a small but steady gap; a four-legged animal's head from its tail hardly at all (its
template has legs at both ends, and the embedding facing backwards often costs less). Two more things weigh:

3. The outline's head/tail cue (``head_tail_cue``): a head and neck reach farther beyond the feet than a tail,
   and a muzzle is carried higher than a tail's end; and the limb ends' bulk (``ends.end_bulk_cue``): a head
   is thick next to its tip, a tail thin, which a cartoon's big head over its front legs and raised tail do
   not hide; where the body's weight lies between the feet (``ends.weight_share_cue``): most animals carry
   more of it on their front legs; where the shape's crest lies between the feet (``crest_cue``): a head
   with its ears or horns is carried highest, a long tail straight back is not; and which way the feet point
   (``ends.toes_cue``): toes and hooves reach forward of the leg, however the head and tail are carried (an
   animal grazing or walking with its head low turns the others round). Their weights are the template's
   ``head_tail``, ``head_bulk``, ``head_share``, ``head_crest`` and ``head_toes``, learned together by
   ``autorig learn`` from how far the embedding alone gets front and back wrong on its examples (0: not used).
   They count only against a frame whose opposite (same up, facing the other way) they favour
   (``cue_penalty``): they tell front from back, never up. Between two frames that share up and face opposite ways, the
   embedding's penalty difference counts at most the template's ``head_gap`` (learned with the weights; None:
   all of it): a four-legged template fits an animal about as badly either way round, and on shapes it fits
   badly (a cartoon, long legs) the difference is large and as often wrong as right (the corpus animals: the
   embedding alone faces 9 of 31 the right way).
4. For a four-legged template (one whose legs it reads off the mesh), the legs hang below the trunk
   (``thin_above``): the embedding tells a standing animal's up from its down, but walking, its legs apart look
   nearly as much like a back as like legs (0 A.D.'s rhino and aurochs read upside down, 0.24 and 0.64 cheaper).
   A frame whose thin parts lie above its bulk pays ``THIN_ABOVE_WEIGHT`` per height they lie above; the right
   frame never pays (its thin parts lie 0.04-0.38 heights below on the 31 animals at rest, walking, with the head
   low and both).
5. The glTF convention (+y up, facing +z), preferred by a small handicap on every other frame: a tie-breaker.
   It was ten times larger; then every corpus biped turned to face -z kept facing +z (0 of 24), since the
   embedding tells a biped's front from its back by about 0.1-0.4.

Explicit ``--up`` / ``--front`` always win; only the axes given as ``auto`` are searched.

Then x = 0 is moved to the body's mid-plane (``mid_plane``), given axes or not: a shield or a spear held to
one side moves the bounding box's centre, across which the refinement would mirror the limbs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..input.mesh import spread
from ..template import CUE_WEIGHTS
from .ends import FEET_BAND, toes_cue

AXES = ("x", "y", "z")
SYMMETRY_AMBIGUITY = 1.25  # a second axis this close in mirror error is tried as left-right too
CONVENTION_BONUS = 0.05   # penalty per axis a frame off +y up / +z front must beat the convention by
DETECTION_EXPANSIONS = 200  # A* budget per fully searched frame (its greedy embedding is used beyond it)
FULL_SEARCHES = 3            # frames searched after the greedy ranking
DECISION_EXPANSIONS = 6_000  # A* budget for a frame that could still win (``settle``)
TIP_BAND = 0.05   # the part of the shape's length at each end whose height is its tip's
CREST_BAND = 0.05  # the part of the shape's height at its top whose place along z is its crest's
MID_PLANE_RANGE = 0.3  # the mid-plane is looked for this fraction of the box's width either side of its centre
MID_PLANE_STEPS = 8    # grid steps on each side of the centre, before the search between the best's neighbours
FINE_STEPS = 8         # ... a finer grid's steps each side of the best, then the search between its best's
MID_PLANE_SAMPLES = 300  # vertices mirrored (each plane tried costs an exact distance query per vertex)
MID_PLANE_MIN_SHIFT = 1e-3  # heights: a mid-plane closer to the box's centre moves no joint that matters
AXIS_PLANE_STEPS = 4      # the same, coarser, for telling the left-right axis (the bounded search still runs:
AXIS_PLANE_SAMPLES = 200  # the grid alone misses a shield's mid-plane, 5 % of the width off the box's centre)
THIN = 0.5                # a medial sphere under this share of the widest one's radius is a thin part's
THIN_ABOVE_WEIGHT = 10.0  # penalty per height the thin parts' middle lies above the bulk's (``thin_above``)


@dataclass
class Orientation:
    """up, front: the chosen axis specs ('y', '-z', ...); costs {'up/front': embedding penalty (at most the
    opposite frame's plus the template's ``head_gap``), plus the handicap of leaving the glTF convention and
    what the weighted head/tail cues hold against it (``cue_penalty``)} of every candidate tried;
    margin the runner-up's cost minus the winner's (0 when nothing was searched);
    symmetry [3] mirror error of each input axis (fraction of the size; the smallest is left-right)."""
    up: str
    front: str
    costs: dict[str, float] = field(default_factory=dict)
    margin: float = 0.0
    symmetry: list[float] = field(default_factory=list)


def mirror_errors(surface, samples: int = 1000) -> np.ndarray:
    """[3] how far the mirror image of a surface lies from the surface, mirrored across the plane through the
    bounding-box centre normal to x, y and z in turn (mean distance / bounding-box diagonal).
    ``surface`` is a ``SurfaceQuery`` in a frame whose axes are the input's (any scale and origin)."""
    vertices = surface.vertices
    # Spread vertices: enough to rank three axes, and each costs a distance query per axis.
    points = vertices[spread(vertices, samples)]
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    out = np.zeros(3)
    for axis in range(3):
        mirrored = points.copy()
        mirrored[:, axis] = 2 * centre[axis] - mirrored[:, axis]
        out[axis] = float(np.mean(surface.distance(mirrored))) / diagonal
    return out


def mid_plane(distance, vertices: np.ndarray, samples: int = MID_PLANE_SAMPLES, bounds=None) -> float:
    """The x of the plane normal to x across which the surface is most nearly its own mirror image: the body's
    mid-plane, which a prop held to one side (a shield, a spear) moves off the bounding box's centre. The
    refinement mirrors left and right joints across x = 0 and the learned placement centres the template
    there, so a rig of a character with a shield would otherwise lean towards the shield.

    distance: unsigned distance [N] to the surface of points [N, 3] (canonical frame, x the left-right axis);
    vertices [V, 3] the surface's vertices in that frame (``mirror_plane``). A plane within
    ``MID_PLANE_MIN_SHIFT`` of the box's centre gives exactly 0, the canonical frame's own x = 0: then nothing
    needs moving. bounds: as ``mirror_plane``'s."""
    centre = (float(vertices[:, 0].min()) + float(vertices[:, 0].max())) / 2
    x = mirror_plane(distance, vertices, 0, samples, bounds=bounds)[0]
    return x if abs(x - centre) >= MID_PLANE_MIN_SHIFT else 0.0


def mirror_plane(distance, vertices: np.ndarray, axis: int, samples: int = MID_PLANE_SAMPLES,
                 steps: int = MID_PLANE_STEPS, exact: bool = True, points: np.ndarray | None = None,
                 bounds=None) -> tuple[float, float]:
    """(position, error) of the plane normal to ``axis`` across which the surface is most nearly its own mirror
    image. The error of a plane is the median distance of the mirrored vertices to the surface (in the
    vertices' units), so that a prop whose mirror image lands far from everything does not pull the plane its
    way; the box's centre stays unless another plane does better. The planes tried: a grid of ``steps`` on
    each side of the centre, then (``exact``) a grid of ``FINE_STEPS`` each side between the grid's best one's
    neighbours, and a bounded search between the finer grid's best one's neighbours.

    distance: unsigned distance [N] to the surface of points [N, 3], each point's alone (the same in any
    batch); vertices [V, 3] the surface's vertices; points: ``vertices[spread(vertices, samples)]`` when the
    caller has them already (the same for each axis); bounds: (lower [N], upper [N]) bounds of ``distance``
    of points [N, 3] that cost no exact query (``DistanceField.surface_distance_bounds``), or None.

    The same planes and errors, with fewer exact queries: a plane's error is the median of exact distances
    only of the points whose bounds could hold it (``_median_within``), the bounds those given and those of
    the nearest plane measured before (a point mirrored across a plane moved by s moves by 2 s, and its
    distance by at most that). With ``bounds``, the grid's planes are measured in the order of the medians of
    their lower bounds, the centre's first, and those whose lower median exceeds the least error measured are
    left: they cannot be the grid's best (four mirror planes of a 60k-face mannequin: 21.6k points queried ->
    ~4k)."""
    from scipy.optimize import minimize_scalar
    points = vertices[spread(vertices, samples)] if points is None else points
    lo, hi = float(vertices[:, axis].min()), float(vertices[:, axis].max())
    centre, width = (lo + hi) / 2, hi - lo
    measured = []       # (plane, lower [N], upper [N]) of each plane measured: exact where queried
    margin = 1e-9 * float(np.linalg.norm(np.ptp(points, axis=0))) if len(points) else 0.0

    def mirrored_at(x: float) -> np.ndarray:
        mirrored = points.copy()
        mirrored[:, axis] = 2 * x - points[:, axis]
        return mirrored

    def given(mirrored: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if bounds is None:
            return np.zeros(len(mirrored)), np.full(len(mirrored), np.inf)
        return bounds(mirrored)

    def measure(x: float, mirrored: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
        if not len(points):
            return float(np.median(distance(mirrored)))
        if measured:
            near, below, above = min(measured, key=lambda m: abs(m[0] - x))
            shift = 2 * abs(x - near) * (1 + 1e-9) + margin      # widened for rounding
            lower, upper = np.maximum(lower, below - shift), np.minimum(upper, above + shift)
        value, lower, upper = _median_within(lower, upper, lambda rows: distance(mirrored[rows]))
        measured.append((x, lower, upper))
        return value

    def error(x: float) -> float:
        mirrored = mirrored_at(x)
        return measure(x, mirrored, *given(mirrored))

    def on_grid(grid: np.ndarray, first: int) -> np.ndarray:
        """[G] the errors of the planes at ``grid``, measured from ``first`` on; inf for a plane that cannot
        be the grid's best (with ``bounds``: its lower bounds' median over the least error measured)."""
        if bounds is None or not len(points):
            return np.array([error(x) for x in grid])
        mirrored = [mirrored_at(x) for x in grid]
        known = [given(m) for m in mirrored]
        floor = [float(np.median(lower)) for lower, _ in known]     # at most each plane's error
        errors = np.full(len(grid), np.inf)     # a plane left is worse than the least error measured
        least = np.inf
        for i in [first] + sorted((i for i in range(len(grid)) if i != first), key=lambda i: (floor[i], i)):
            if i != first and floor[i] > least:
                break
            errors[i] = measure(float(grid[i]), mirrored[i], *known[i])
            least = min(least, errors[i])
        return errors

    # A grid first: the error can have several local minima, and the bounded search needs a bracket.
    grid = centre + width * np.linspace(-MID_PLANE_RANGE, MID_PLANE_RANGE, 2 * steps + 1)
    errors = on_grid(grid, steps)
    best = int(np.argmin(errors))
    x, value = float(grid[best]), float(errors[best])
    if exact:
        # Between the best's neighbours a finer grid, and the bounded search between its best's: the error (a
        # median) is bumpy there, and a search over the whole bracket settled in one dip or another as the floats
        # fell (0 A.D.'s aurochs walking, ``benchmarks/stability.py --animal-poses walk``: every joint read
        # across the plane 0.59 % of the height apart under 1e-6 noise).
        fine = np.linspace(grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)], 2 * FINE_STEPS + 1)
        fine_errors = on_grid(fine, int(np.argmin(np.abs(fine - x))))
        near = int(np.argmin(fine_errors))
        if fine_errors[near] < value:
            x, value = float(fine[near]), float(fine_errors[near])
        found = minimize_scalar(error, bounds=(fine[max(near - 1, 0)], fine[min(near + 1, len(fine) - 1)]),
                                method="bounded", options={"xatol": 1e-4 * width})
        if found.fun < value:
            x, value = float(found.x), float(found.fun)
    return (centre, float(errors[steps])) if value >= errors[steps] else (x, value)


def _median_within(lower: np.ndarray, upper: np.ndarray, exact) -> tuple[float, np.ndarray, np.ndarray]:
    """(``np.median`` of values d [N] known to lie in [lower, upper], the bounds with the values queried put
    in): ``exact(rows)`` gives d[rows] [R], asked for only of the rows that could be a middle value. The
    middle values (ranks k1 = (N-1)//2 and k2 = N//2) lie between the k1-th smallest lower bound and the
    k2-th smallest upper one; a row whose upper bound is below that range is below them (and a lower one above
    it, above them), so the middle values are the queried rows' values at ranks k1 and k2 less the rows
    below: the same number ``np.median(d)`` gives."""
    n = len(lower)
    k1, k2 = (n - 1) // 2, n // 2
    low = np.partition(lower, k1)[k1]
    high = np.partition(upper, k2)[k2]
    below = upper < low
    rows = np.flatnonzero(~below & ~(lower > high))
    values = np.asarray(exact(rows), dtype=np.float64)
    lower, upper = lower.copy(), upper.copy()
    lower[rows] = upper[rows] = values
    skip = int(below.sum())
    ordered = np.sort(values)
    return float(np.median(ordered[k1 - skip:k2 - skip + 1])), lower, upper


def head_tail_cue(vertices: np.ndarray) -> float:
    """How surely a shape faces +z rather than -z by its outline alone, in heights, clipped to [-1, 1]
    (positive: its head is at +z). vertices [V, 3] in a candidate frame (+y up, front along z).

    Two signs of a head: the shape reaches farther beyond its feet forward than backward (a head on its neck
    stands out more than a tail, and a long tail is thin), and its front tip is higher than its back tip (a
    muzzle is carried higher than a tail's end). Turning the shape round negates the cue."""
    y, z = vertices[:, 1], vertices[:, 2]
    height = float(np.ptp(y))
    if height <= 0:
        return 0.0
    feet = z[y <= y.min() + FEET_BAND * height]
    reach = (z.max() - feet.max()) - (feet.min() - z.min())
    band = TIP_BAND * float(np.ptp(z))
    tips = float(np.mean(y[z >= z.max() - band]) - np.mean(y[z <= z.min() + band]))
    return float(np.clip((reach + tips) / height, -1.0, 1.0))


def crest_cue(vertices: np.ndarray) -> float:
    """How surely a shape faces +z rather than -z by where its top lies, in [-1, 1] (positive: the head is at
    +z): the mean z of the vertices in the top ``CREST_BAND`` of its height, minus the feet's middle, over half
    the feet's spread along z (-1 over the back feet, +1 over the front ones), clipped. A head, its ears or
    horns are most animals' highest part; a tail held out straight behind (a fox's, a wolf's) reaches far and
    ends high, but below the ears. Turning the shape round negates it. vertices [V, 3] in a candidate frame
    (+y up, front along z)."""
    y, z = vertices[:, 1], vertices[:, 2]
    height = float(np.ptp(y))
    if height <= 0:
        return 0.0
    feet = z[y <= y.min() + FEET_BAND * height]
    half = (feet.max() - feet.min()) / 2
    if half <= 0:
        return 0.0
    top = z[y >= y.max() - CREST_BAND * height]
    return float(np.clip((top.mean() - (feet.min() + feet.max()) / 2) / half, -1.0, 1.0))


def weighted_cues(template, graph, vertices: np.ndarray, toes: float = 0.0) -> float:
    """The template's head/tail cues of a shape in a candidate frame, weighed (penalty units, positive: its
    head is at +z): the outline's (``head_tail_cue``), the limb ends' bulk (``ends.end_bulk_cue``), the
    weight share (``ends.weight_share_cue``), the crest's place (``crest_cue``) and the feet's, ``toes``
    (``ends.toes_cue``, read by the caller: turning the shape round negates it, so one read serves two frames).
    graph: the sphere graph in that frame; vertices [V, 3] the surface's vertices in it."""
    from .ends import end_bulk_cue, weight_share_cue
    outline = template.head_tail * head_tail_cue(vertices) if template.head_tail else 0.0
    bulk = template.head_bulk * end_bulk_cue(graph, vertices) if template.head_bulk else 0.0
    share = template.head_share * weight_share_cue(graph, vertices) if template.head_share else 0.0
    crest = template.head_crest * crest_cue(vertices) if template.head_crest else 0.0
    return outline + bulk + share + template.head_toes * toes + crest


def bounded_costs(costs: dict, gap: float | None, floor: dict | None = None) -> dict:
    """{frame: cost} with each frame's cost at most its opposite's (same up, front reversed) plus ``gap``
    (``Template.head_gap``; None: unchanged): the embedding's front/back difference, bounded.
    costs: {(up, front): penalty}; floor: {(up, front): a lower bound on the penalty} to bound instead of
    the frame's own cost (its opposite's cost still bounds it: a lower bound on the bounded cost)."""
    own = floor if floor is not None else costs
    if gap is None:
        return dict(own)
    out = {}
    for (u, f), cost in own.items():
        opposite = (u, _flipped(f))
        out[(u, f)] = min(cost, (floor or costs).get(opposite, np.inf) + gap)
    return out


def working_axes(up: str, front: str) -> tuple[str, str]:
    """The frame to discretize in: always the input's own axes (y, z), so that detection can mirror across
    them, and so that axes given by the user give the rig that detecting the same axes gives (the
    discretization is then the same one, carried into the frame by ``reorient``); ``up`` and ``front`` are
    taken for the callers' sake and do not change it."""
    return ("y", "z")


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


def detect_orientation(prepared, field, graph, template, up: str = "auto", front: str = "auto") -> Orientation:
    """Choose the axes given as 'auto' (see the module docstring).

    prepared, field, graph: the mesh, distance field and sphere graph in the frame of ``working_axes``;
    template: the Template to be embedded.
    """
    if up != "auto" and front != "auto":
        return Orientation(up, front)
    symmetry = mirror_errors(field.surface)
    # A posed character (a galloping horse) can be nearly as symmetric across a second axis: then both are
    # tried as left-right. The user's up is never left-right (trust a character lying on its side).
    order = [a for a in np.argsort(symmetry, kind="stable") if up == "auto" or a != AXES.index(up[-1])]
    left_axes = [a for a in order[:2] if symmetry[a] <= SYMMETRY_AMBIGUITY * symmetry[order[0]] + 1e-4]
    # A spear held forward or a shield to one side moves the box's centre, across which ``mirror_errors``
    # mirrors: the axis most nearly symmetric across its own best plane is tried too.
    spread_vertices = prepared.work_vertices[spread(prepared.work_vertices, AXIS_PLANE_SAMPLES)]
    planes = [mirror_plane(field.surface_distance, prepared.work_vertices, a, AXIS_PLANE_SAMPLES,
                           AXIS_PLANE_STEPS, points=spread_vertices, bounds=field.surface_distance_bounds)[1]
              for a in range(3)]
    best_plane = next(a for a in np.argsort(planes, kind="stable") if up == "auto" or a != AXES.index(up[-1]))
    left_axes += [best_plane] if best_plane not in left_axes else []
    candidates = list(dict.fromkeys(c for a in left_axes for c in candidate_frames(up, front, int(a))))
    # Greedy embeddings rank the frames (an upside-down frame costs many times more); the best few are then
    # searched on a short budget, and those that could still win longer (``settle``).
    problems, cues, toes = {}, {}, {}
    for u, f in candidates:
        change = prepared.frame_change(u, f)
        moved = graph.moved(change.apply(graph.centers), change.scale)
        problems[(u, f)] = _problem(moved, template)
        # the vertices carried into the frame only for a template that weighs a cue (the biped weighs none)
        if not any(getattr(template, key) for key in CUE_WEIGHTS):
            cues[(u, f)] = 0.0
            continue
        vertices = change.apply(prepared.work_vertices)
        if template.head_toes:    # the costliest cue, which turning the shape round negates (to ~1e-15)
            back = toes.get((u, _flipped(f)))
            toes[(u, f)] = -back if back is not None else toes_cue(moved, vertices, prepared.work_faces)
        cues[(u, f)] = weighted_cues(template, moved, vertices, toes.get((u, f), 0.0))
    # A four-legged template's legs hang below its trunk, however it carries its head (``thin_above``).
    above = {key: thin_above(problems[key].graph) if template.legs and problems[key] is not None else 0.0
             for key in candidates}
    prior = {key: _handicap(*key) + cue_penalty(cues, key) + THIN_ABOVE_WEIGHT * max(above[key], 0.0)
             for key in candidates}
    costs = {key: _embedding_cost(problem, 0)[0] for key, problem in problems.items()}
    bounds = {}
    for key in sorted(costs, key=lambda k: (costs[k] + prior[k], k))[:FULL_SEARCHES]:
        costs[key], bounds[key] = _embedding_cost(problems[key], DETECTION_EXPANSIONS)
    gap = template.head_gap
    costs = settle(costs, bounds, prior, gap, lambda key: _embedding_cost(problems[key], DECISION_EXPANSIONS))
    costs = {f"{u}/{f}": cost + prior[(u, f)] for (u, f), cost in bounded_costs(costs, gap).items()}
    ranked = sorted(costs, key=lambda k: (costs[k], k))
    margin = costs[ranked[1]] - costs[ranked[0]] if len(ranked) > 1 else 0.0
    u, f = ranked[0].split("/")
    return Orientation(u, f, costs, float(margin), [float(v) for v in symmetry])


def settle(costs: dict, bounds: dict, prior: dict, gap: float | None, search_long) -> dict:
    """{frame: embedding cost} once no frame's A* bound says it could still beat the leader: the frames of
    ``bounds`` ({frame: lower bound} of those searched so far; ``costs`` {frame: best embedding's cost found},
    ``prior`` {frame: handicap and cues}) are searched longer (``search_long(frame)`` -> (cost, bound)), the
    leader first, then the rival with the lowest bound, each at most once: branch and bound over the frames.

    A short search can leave the right frame's embedding many times its optimum (a deer facing the right way,
    11.9 against 1.9; a stag with antlers standing up, 8.5 against 2.5, lost to a frame lying along its back
    at 8.2 whose optimum is 10.0). A frame whose search finished (bound = cost) is never searched again. A
    template's ``head_gap`` bounds how much two opposite frames' embeddings differ (``bounded_costs``)."""
    costs, bounds, searched_long = dict(costs), dict(bounds), set()
    while len(bounds) > 1:
        bounded = bounded_costs({k: costs[k] for k in bounds}, gap)
        lower = bounded_costs({k: costs[k] for k in bounds}, gap, {k: bounds[k] for k in bounds})
        leader = min(bounds, key=lambda k: (bounded[k] + prior[k], k))
        best = bounded[leader] + prior[leader]
        rivals = sorted((k for k in bounds if k != leader and lower[k] + prior[k] < best),
                        key=lambda k: (lower[k] + prior[k], k))
        todo = [k for k in [leader] + rivals if bounds[k] < costs[k] and k not in searched_long]
        if not rivals or not todo:
            break
        costs[todo[0]], bounds[todo[0]] = search_long(todo[0])
        searched_long.add(todo[0])
    return costs


def thin_above(graph) -> float:
    """How far above the body's bulk its thin parts lie in ``graph``'s frame (+y up), over the spheres' height:
    the thin spheres' (radius under ``THIN`` of the widest) mean height, weighted by their cross-sections, less
    the thick ones', weighted by their volumes. An animal's legs hang below its trunk whether it stands, walks or
    grazes, so the right frame reads below (the 31 animals at rest, walking, with the head low and both: -0.04
    to -0.38 heights), and the frame upside down the same above. The embedding alone nearly ties the two
    for a walking animal, whose legs apart look as much like a back as like legs (0 A.D.'s rhino and aurochs,
    upside down 0.24 and 0.64 cheaper). 0 when every sphere is thin or none is."""
    c, r = graph.centers, graph.radii
    thin = r < THIN * r.max()
    if not thin.any() or thin.all():
        return 0.0
    height = float(np.ptp(c[:, 1])) or 1.0
    return float((np.average(c[thin, 1], weights=r[thin] ** 2) - np.average(c[~thin, 1], weights=r[~thin] ** 3))
                 / height)


def cue_penalty(cues: dict, frame: tuple[str, str]) -> float:
    """How much the weighted head/tail cues ({(up, front): ``weighted_cues``}) hold against ``frame``: by how
    much they favour the frame with the same up facing the other way (0 when they favour this one, or when that
    frame is not a candidate). The cues tell front from back and nothing else: in a frame with the wrong up
    they read a leg or the back as a head, and must not outweigh the embedding there (a stag read lying on its
    side, its antlers the top of its body: 7.5 against 7.7 had the cues counted in full)."""
    opposite = (frame[0], _flipped(frame[1]))
    return max(cues.get(opposite, -np.inf) - cues[frame], 0.0)


def _flipped(axis: str) -> str:
    return axis[1:] if axis.startswith("-") else "-" + axis


def _handicap(up: str, front: str) -> float:
    return CONVENTION_BONUS * ((up.lstrip("+") != "y") + (front.lstrip("+") != "z"))


def _problem(graph, template):
    """The embedding problem of ``template`` on ``graph``, or None if the template cannot fit it at all."""
    from .penalties import build_problem
    from ..errors import RigFailedError
    from ..input.budget import OverBudget
    try:
        return build_problem(graph, template)
    except OverBudget:
        raise
    except RigFailedError:
        return None


def _embedding_cost(problem, expansions: int) -> tuple[float, float]:
    """(penalty of the best embedding found within ``expansions`` A* steps (0: greedy only), a lower bound on
    any embedding's: the penalty itself when the search finished); (inf, inf) if there is none."""
    from .search import search
    from ..errors import RigFailedError
    from ..input.budget import OverBudget
    if problem is None:
        return float("inf"), float("inf")
    try:
        found = search(problem, max_expansions=expansions)
    except OverBudget:
        raise
    except RigFailedError:
        return float("inf"), float("inf")
    return float(found.cost), float(found.bound)


def centre_on_mid_plane(prepared, field, graph):
    """(prepared, field, graph) moved along x so that x = 0 is the body's mid-plane (``mid_plane``)."""
    x = mid_plane(field.surface_distance, prepared.work_vertices, bounds=field.surface_distance_bounds)
    if x == 0.0:
        return prepared, field, graph
    offset = np.array([-x, 0.0, 0.0])
    return prepared.centred_at(x), field.moved(np.eye(3), offset, 1.0), graph.moved(graph.centers + offset, 1.0)


def reorient(prepared, field, graph, orientation: Orientation):
    """(prepared, field, graph) carried into the frame of ``orientation`` (unchanged if already in it)."""
    if (prepared.up, prepared.front) == (orientation.up, orientation.front):
        return prepared, field, graph
    moved = prepared.reframed(orientation.up, orientation.front)
    change = moved.change_from(prepared)
    return (moved, field.moved(change.rotation, change.offset, change.scale),
            graph.moved(change.apply(graph.centers), change.scale))
