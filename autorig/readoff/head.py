"""The head joint read off the mesh: the skull's pivot, a skull's length behind the snout, not the template's.

The embedding's head chain often stops short of the snout (a boar's, a pig's, a rhino's) or climbs a horn, and
the placement pulls a raised head toward the template's; even a chain that reaches the snout leaves its head
joint where the template's proportions put it (the aurochs's 14 % of the extent from its artist's). An artist's
head joint is the head's pivot, where the skull meets the neck (or the body, without a neck), and a skull is
about as long as a number of its own depths. In the canonical frame (+y up, one unit tall, facing +z), on the
body's mid-plane (the x half-way between the front legs' feet), over a grid of ``STEP``:

    paws       the front feet's mean z
    tip        going forward from the paws, the last z whose mid-plane column is still inside the mesh (the
               snout's end; a horn or a tusk off the mid-plane does not count)
    thickness  the thickest mid-plane column (its top minus its bottom) within a share a of the way from the
               snout back to the paws: the head's depth, a being the least share at which any example's artist
               put the head, so that the window holds only head in every example
    column     at z: its deepest point's height and its depth (half-thickness)

and the joint goes c thicknesses behind the snout, but at least a share k of the way back to the paws, at
``deepest + m * depth`` of its column: (x, deepest + m * depth, tip - max(c * thickness, k * (tip - paws))).
A column whose deepest point lies more than ``NECK_COLUMN`` thicknesses below or above the snout's height is a
neck's, not a head's: a raised head on a long upright neck (an alpaca's, a camel's) stands on a column that
runs down the neck into the chest, deepest at the neck's base, and the head went there (the Quaternius alpaca's
2.3 thicknesses below its snout, 27 % of the extent from its artist's head with the horse template). There the
joint goes at the snout's height instead (the alpaca's artist: 0.01 thicknesses below it), blended between the
two over ``NECK_COLUMN`` so that the joint does not jump. On the 31 animals the columns' deepest points lie
0.16 below to 0.78 above their snout's height, but for the alpaca's, so no other head moves.
c and m are the medians over the examples, a their least share and k their lower quartile (``learn_head``).
The share alone, the rule before, put every head at one share of the way (the artists' range 0.38-0.85 over the
0 A.D., Quaternius and glTF animals), and a big-headed creature's pivot sits at its shoulders (OpenClonk's
wipf, mooq and puka: 1.05-1.35), 16-25 % of the extent from where that share put it; the thickness alone put a
long, low head (the rhino's) 16 % short. The floor k was chosen on the 31 animals among 0, 0.1, ..., 0.5 of
the shares' quantiles (0.2-0.3 rig alike; 0 leaves the rhino at 16 %, 0.4-0.5 move the alpaca's raised head
27 %), not cross-validated. The rule is taken whether or not the embedding's head chain reached the snout: the
embedding's own head, kept where its chain reached the snout, was the worse on those animals (the aurochs 14
against 9 %, the Quaternius bull, cow, deer and horse 10-11 against 9, 9, 6 and 5 %; see docs/tutorials/learn.md).
The neck, when it no longer sits between the chest and the new head along the back, goes half-way between them.
A head carried low (an animal grazing, or walking with its head down) is measured wrongly by this rule: its vertical
columns cut head and neck on the slant (0 A.D.'s wolf with its neck turned 40 degrees down: 0.36 thick against 0.19
standing, measured by hand) and the snout comes back toward the paws, and the head went into the neck, up to 28 % of
the extent from its artist's (mean 16.4 % over the 31 animals, cross-validated by species, the neck turned 40
degrees down or as far as the ground lets it). The *frame rule* reads the head in its own frame instead:
``HeadPath`` is the mid-plane's middle path from the paws' column to the snout, which the head carries with it, its
width measured across the path; the head goes c' widths (the widest within a share a' of the path from the snout)
along it, at least a share k' of its length or of the snout's reach from the shoulders, whichever is shorter
(``HeadPath.span``), m' half-widths toward the back (the same medians and quantiles over the examples,
``learn_frame``). Standing, it is the worse rule (about 6 % mean against 5.1 by hand, the mooq's 31 %: a
neckless head the path does not reach behind), so it does not replace the skull rule: the skull rule's head stays
unless it lies further along the path from the frame rule's than the frame rule's own tolerance d (the
``FRAME_QUANTILE`` of its errors on the examples, in the snout's reach from the shoulders, which a turned neck
keeps), and is taken over to the frame rule's over a further ``FRAME_RAMP`` x d (``in_frame``). ``python
benchmarks/head_rules.py`` (the artists' paws, by species / by source): standing 5.1 / 5.2 % mean, 13.1 / 15.2
worst (the mooq by source; the skull rule alone 5.1 / 5.0, 13.1 / 13.7), the head lowered 8.4 / 9.7 % mean and 3 / 6
of the 31 beyond 15 % (16.4 / 16.2, 16 / 17). The floor was a share of the path's length: the long-necked deer and
giraffe, whose path from the paws' column runs up the whole neck when lowered, had the head down the neck (15-21 %;
a share of the reach alone put the Quaternius dogs' lowered heads, whose short paths reach far, 9-16 % off; k
learned as a share of the span, not of the length, moved the mooq's standing head 13.7 -> 15.1 % by source); with it
the lowered head was 9.3 / 10.4 % mean, 5 / 8 beyond 15. Heads
lowered the frame rule does not reach: the hippopotamus, whose chin against its chest makes the path's width run
on into the chest (by hand 0.69 against 0.15 standing; capping the width at 3 times the path's clearance: the head
lowered 9.3 -> 8.2 % mean by species, 5 -> 3 beyond 15 %, but the mooq's standing head 11.5 -> 19-20 % in whole
rigs: not kept; the width read as the path's clearance: 9.6 -> 11.3 % by source); the wildebeest, whose face hangs
straight down, so that its forehead lies as far along the mid-plane from the paws' column as its snout, and the
path ends on the forehead (ending it at the rig's head chain's end where that lies nearly as far along: 19 rigs
right before were wrong after, in ``benchmarks/animals.py``, the chain often stops short of the snout).
The template's ``legs`` carries the rules as ``{"head": {"skull": [c, a, k, m], "frame": [c', a', k', m', d]}}``
(the frame rule only beside the skull rule; without it, the skull rule alone). The older ``{"head":
{"snout": [k, m]}}`` (the head a share k of the way back from the snout, unless the head chain ended within
``REACHED`` of it) is still read as it was. A template without either, or a mesh whose snout or head column
cannot be measured, keeps its joints.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

STEP = 0.01
JOINT = "head"
NECK, CHEST = "neck", "chest"
MIN_EXAMPLES = 4
# The older "snout" rule's bounds: how near the snout's end (in heights) the embedding's head chain had to end for
# its head to be kept, blended between the two.
REACHED = (0.03, 0.07)
RULES = ("skull", "snout")    # the learned rule, and the one before it (a share of the way from snout to paws)
FLOOR = 0.25                  # the quantile of the examples' shares that is the skull rule's floor k
NECK_COLUMN = (1.0, 1.5)      # thicknesses from the snout's height: the column's deepest point is the head's
                              # below the first, a neck's beyond the second (the joint at the snout's height)
# The head's own frame (``HeadPath``): the path from the paws' column to the snout keeps to the middle of the
# mid-plane by costing each step its length over the square of its distance to the outline; it is smoothed over
# 2 * PATH_SMOOTH + 1 cells. The frame rule's tolerance d is this quantile of its own errors on the examples, and
# the skull rule's head is taken over to the frame rule's over a further RAMP x d.
PATH_POWER = 2
PATH_SMOOTH = 3
FRAME_QUANTILE = 0.9
FRAME_RAMP = 0.5


@dataclass
class Head:
    """What ``measure_head`` reads off a mesh (canonical frame).

    x          the mid-plane's x (half-way between the front feet)
    paws       the front feet's mean z
    snout      [3] (x, the tip column's deepest point, tip)
    column     z -> (deepest point's height, depth) of the mid-plane's column at z, or None when not inside
    thickness  share a -> the thickest mid-plane column (top minus bottom) within a * (tip - paws) of the tip
    path       the head's own frame (``HeadPath``), or None
    """
    x: float
    paws: float
    snout: np.ndarray
    column: Callable
    thickness: Callable
    path: "HeadPath | None" = None

    @property
    def tip(self) -> float:
        return float(self.snout[2])


def measure_head(depth, vertices: np.ndarray, joints: np.ndarray, template) -> Head | None:
    """The ``Head`` of a mesh from its signed ``depth`` (points [N, 3] -> [N], > 0 inside), its ``vertices``
    [V, 3] and the front feet in ``joints`` [J, 3] (canonical frame); None without front legs or a snout ahead
    of them."""
    from .legs import legs_of
    from .rump import midplane_depths
    feet = np.array([joints[chain[-1]] for chain in legs_of(template)]).reshape(-1, 3)
    roots = np.array([joints[chain[0]] for chain in legs_of(template)]).reshape(-1, 3)
    if len(feet) < 4:
        return None
    front = feet[roots[:, 2] >= np.median(roots[:, 2])]
    x, paws = float(front[:, 0].mean()), float(front[:, 2].mean())
    Y = np.arange(float(vertices[:, 1].min()), float(vertices[:, 1].max()), STEP)
    Z = np.arange(paws, float(vertices[:, 2].max()) + STEP, STEP)
    if len(Y) < 2 or len(Z) < 2:
        return None

    def grid(z: np.ndarray) -> np.ndarray:      # [len(z), len(Y)] depths of the mid-plane's columns at z
        return midplane_depths(depth, x, z, Y)

    columns = grid(Z) > 0                        # [Z, Y] inside
    inside = np.nonzero(columns.any(axis=1))[0]
    if not len(inside) or Z[inside[-1]] - paws < 2 * STEP:
        return None
    tip = float(Z[inside[-1]])
    rows = np.arange(len(Y))
    tops = np.where(columns, rows, -1).max(axis=1)
    bottoms = np.where(columns, rows, len(Y)).min(axis=1)
    thick = np.where(tops >= 0, (tops - bottoms) * STEP, 0.0)     # [Z] each column's top minus its bottom

    def column(z: float):
        d = grid(np.array([z]))[0]
        return None if d.max() <= 0 else (float(Y[int(np.argmax(d))]), float(d.max()))

    def thickness(share: float) -> float:
        return float(thick[(Z >= tip - share * (tip - paws) - 1e-9) & (Z <= tip)].max(initial=0.0))
    shoulders = roots[roots[:, 2] >= np.median(roots[:, 2])].mean(axis=0)
    return Head(x, paws, np.array([x, column(tip)[0], tip]), column, thickness,
                head_path(columns, x, Y, Z, shoulders))


def edge_max(s: np.ndarray, values: np.ndarray, end: float) -> float:
    """The largest of ``values`` [N] at increasing positions ``s`` [N] (from 0) up to ``end``, the value at ``end``
    itself read linearly between its two neighbours: a window's widest grows steadily as the window does, not by a
    whole step when its end passes a point (0 A.D.'s polar bear with its head low, its head path 0.004 shorter
    under 1e-6 noise: one more point in the window, the widest 0.12 -> 0.21, the head 17 % of the extent away;
    8.4 % with this and the rule relearned). The frame rule's window only: the skull rule's read the same way rigged
    the four poses of ``benchmarks/animals.py`` alike but for the sheep's lowered head (right since) and the
    aurochs's standing one (10.4 -> 12.3 % by source), and is left as it was."""
    inside = values[(s <= end) & (s >= 0)]
    edge = float(np.interp(end, s, values)) if len(s) and s[0] <= end else 0.0
    return float(max(inside.max(initial=0.0), edge))


@dataclass
class HeadPath:
    """The head in its own frame: the mid-plane's middle path from the front paws' column to the snout, which
    a lowered or raised head carries with it (``head_path``).

    points   [P, 3] along the path, the snout's end first
    half     [P] half the mid-plane's width across the path there
    normals  [P, 3] across the path, toward the back's side (+y on a level head)
    arc      [P] the length along the path from the snout's end
    reach    the snout's end's distance from the front shoulders (as far, however the neck is turned)
    """
    points: np.ndarray
    half: np.ndarray
    normals: np.ndarray
    arc: np.ndarray
    reach: float

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    @property
    def span(self) -> float:
        """What the frame rule's floor is a share of: the path's length, but no more than the snout's reach from
        the shoulders. A long neck lowered lengthens the path from the paws' column (0 A.D.'s deer 0.39 -> 0.99
        of the height, its reach 0.43 -> 0.66) and a share of the length put the head down the neck."""
        return min(self.length, self.reach)

    def thickness(self, share: float) -> float:
        """The widest across the path within ``share`` of its length from the snout, the width at the window's
        end read between the path's points (``edge_max``)."""
        return 2 * edge_max(self.arc, self.half, share * self.length)

    def at(self, s: float) -> int:
        """The point ``s`` along the path from the snout (the last if beyond it)."""
        return int(np.clip(np.searchsorted(self.arc, s), 0, len(self.arc) - 1))

    def nearest(self, point: np.ndarray) -> int:
        return int(np.argmin(np.linalg.norm(self.points - point, axis=1)))

    def along(self, point: np.ndarray) -> float:
        """How far along the path from the snout ``point`` lies (its nearest point's length)."""
        return float(self.arc[self.nearest(point)])

    def place(self, rule: list[float]) -> np.ndarray:
        """Where the frame rule [c, a, k, m, ...] puts the head: c thicknesses (within a share a of the path's
        length) along the path from the snout, but at least a share k of its ``span``, m half-widths toward the
        back."""
        i = self.at(max(rule[0] * self.thickness(rule[1]), rule[2] * self.span))
        return self.points[i] + rule[3] * self.half[i] * self.normals[i]


def head_path(inside: np.ndarray, x: float, Y: np.ndarray, Z: np.ndarray, shoulders: np.ndarray) -> HeadPath | None:
    """The ``HeadPath`` of a mid-plane grid ``inside`` [Z, Y] (Z from the front paws forward, steps of ``STEP``):
    from the paws' column (its part joined to the snout), the cheapest path to the cell farthest from it along
    the inside (the snout's end), each step costing its length over the square of its distance to the outline
    (``PATH_POWER``) so that it keeps to the middle; None when the column is outside the mesh."""
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra
    labels, _ = ndimage.label(inside, structure=np.ones((3, 3)))
    keep = np.isin(labels, np.unique(labels[0][inside[0]]))
    if not inside[0].any() or keep.sum() < 3:
        return None
    clearance = ndimage.distance_transform_edt(keep) * STEP
    index = np.full(keep.shape, -1)
    index[keep] = np.arange(int(keep.sum()))
    rows, cols, lengths, costs = [], [], [], []
    nz, ny = keep.shape
    for dz, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
        a = (slice(0, nz - dz), slice(max(0, -dy), ny - max(0, dy)))
        b = (slice(dz, nz), slice(max(0, dy), ny + min(0, dy)))
        both = keep[a] & keep[b]
        step = float(np.hypot(dz, dy)) * STEP
        rows.append(index[a][both])
        cols.append(index[b][both])
        lengths.append(np.full(int(both.sum()), step))
        costs.append(step / (0.5 * (clearance[a][both] + clearance[b][both])) ** PATH_POWER)
    n = int(keep.sum())
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    source = index[0][keep[0]]
    along = dijkstra(coo_matrix((np.concatenate(lengths), (rows, cols)), shape=(n, n)).tocsr(), directed=False,
                     indices=source, min_only=True)
    tip = int(np.argmax(np.where(np.isfinite(along), along, -1.0)))
    _, before, _ = dijkstra(coo_matrix((np.concatenate(costs), (rows, cols)), shape=(n, n)).tocsr(),
                            directed=False, indices=source, min_only=True, return_predecessors=True)
    cells = [tip]
    while before[cells[-1]] >= 0:
        cells.append(int(before[cells[-1]]))
    zi, yi = np.nonzero(keep)
    zi, yi = zi[cells], yi[cells]
    points = np.c_[np.full(len(cells), x), Y[yi], Z[zi]]
    w = 2 * PATH_SMOOTH + 1
    if len(points) > w:
        for c in (1, 2):
            points[PATH_SMOOTH:-PATH_SMOOTH, c] = np.convolve(points[:, c], np.ones(w) / w, mode="valid")
    ahead = -np.gradient(points[:, 1:], axis=0) if len(points) > 1 else np.array([[0.0, 1.0]])
    ahead /= np.maximum(np.linalg.norm(ahead, axis=1, keepdims=True), 1e-12)
    normals = np.c_[np.zeros(len(points)), ahead[:, 1], -ahead[:, 0]]
    steps = np.arange(0.0, 1.0, STEP / 2)

    def out_to(point, direction) -> float:     # how far the inside goes from point along direction
        q = point[None, 1:] + steps[:, None] * direction[None, 1:]
        z, y = np.round((q[:, 1] - Z[0]) / STEP).astype(int), np.round((q[:, 0] - Y[0]) / STEP).astype(int)
        ok = (z >= 0) & (z < nz) & (y >= 0) & (y < ny)
        held = np.zeros(len(q), dtype=bool)
        held[ok] = keep[z[ok], y[ok]]
        out = np.flatnonzero(~held)
        return float(steps[out[0]] if len(out) else steps[-1])
    half = np.array([(out_to(p, m) + out_to(p, -m)) / 2 for p, m in zip(points, normals)])
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    return HeadPath(points, half, normals, arc, float(np.linalg.norm(points[0, 1:] - shoulders[1:])))


def head_place(rule: list[float], key: str, head: Head) -> float:
    """The z the ``key`` rule (``RULES``) puts the head at on the measured ``head``."""
    span = head.tip - head.paws
    if key == "snout":
        return head.tip - rule[0] * span
    return head.tip - max(rule[0] * head.thickness(rule[1]), rule[2] * span)


def read_head(joints: np.ndarray, template, depth, vertices: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` with the head moved by the template's learned rule (``measure_head``) and the neck
    kept between the chest and the head; unchanged without the rule or the measurement."""
    from .rump import ruled_measurement
    key = next((k for k in RULES if k in (template.legs or {}).get(JOINT, {})), None)
    found = None if key is None else ruled_measurement(joints, template, JOINT, key, measure_head, depth, vertices)
    if found is None:
        return joints
    rule, measured = found
    head = template.names.index(JOINT)
    keep = 0.0
    if key == "snout":    # the older rule kept the head of a chain that reached the snout
        ends = [c for c in template.children[head] if not template.children[c]]
        reach = min(float(np.linalg.norm(joints[c] - measured.snout)) for c in ends) if ends else np.inf
        keep = float(np.clip((REACHED[1] - reach) / (REACHED[1] - REACHED[0]), 0.0, 1.0))
        if keep >= 1.0:
            return joints
    z = head_place(rule, key, measured)
    section = measured.column(z)
    if section is None:
        return joints
    height = section[0] + rule[-1] * section[1]
    if key == "skull":
        thickness = measured.thickness(rule[1])
        off = abs(section[0] - float(measured.snout[1])) / max(thickness, 1e-9)
        t = float(np.clip((off - NECK_COLUMN[0]) / (NECK_COLUMN[1] - NECK_COLUMN[0]), 0.0, 1.0))
        height += t * t * (3.0 - 2.0 * t) * (float(measured.snout[1]) - height)
    out = joints.copy()
    out[head] = keep * joints[head] + (1.0 - keep) * np.array([measured.x, height, z])
    frame = (template.legs or {}).get(JOINT, {}).get("frame")
    if key == "skull" and frame is not None and measured.path is not None:
        out[head] = in_frame(out[head], frame, measured.path)
    if NECK in template.names and CHEST in template.names:
        neck, chest = template.names.index(NECK), template.names.index(CHEST)
        # A head moved back past the neck would fold the neck chain over itself; half-way keeps it a chain.
        if not min(out[chest, 2], out[head, 2]) <= out[neck, 2] <= max(out[chest, 2], out[head, 2]):
            out[neck] = (out[chest] + out[head]) / 2
    return out


def in_frame(skull: np.ndarray, frame: list[float], path: HeadPath) -> np.ndarray:
    """The skull rule's head ``skull`` [3], taken over toward the frame rule's (``HeadPath.place``) where the two
    lie further apart along the path than the frame rule's tolerance d (in reaches): all the way at (1 +
    ``FRAME_RAMP``) d, steadily in between."""
    placed = path.place(frame)
    apart = abs(path.along(skull) - path.along(placed)) / max(path.reach, 1e-9)
    w = float(np.clip((apart - frame[4]) / max(FRAME_RAMP * frame[4], 1e-9), 0.0, 1.0))
    return (1.0 - w) * skull + w * placed


def learn_frame(rows: list, joint: int) -> list[float] | None:
    """[c, a, k, m, d] of the frame rule over ``rows`` ((truth [J, 3], ``HeadPath``)): as the skull rule's
    (``learn_head``) but along the path (a, and k, the ``FLOOR`` quantile, of the shares of its length: the
    examples stand, their paths no longer than the snout's reach or nearly, and k is taken of the ``span``), and d,
    the ``FRAME_QUANTILE`` of its own errors along the path in reaches."""
    found = []
    for truth, path in rows:
        i = path.nearest(truth[joint])
        s = float(path.arc[i])
        found.append((path, s, s / max(path.length, 1e-9),
                      float(np.dot(truth[joint] - path.points[i], path.normals[i])) / max(path.half[i], 1e-9)))
    rule = _medians(found, float(min(r[2] for r in found))) if len(found) >= MIN_EXAMPLES else None
    if rule is None:
        return None
    misses = [abs(path.along(path.place(rule)) - s) / max(path.reach, 1e-9) for path, s, _, _ in found]
    return [round(v, 4) for v in rule + [float(np.quantile(misses, FRAME_QUANTILE))]]


def _medians(rows: list, share: float) -> list[float] | None:
    """[c, a, k, m] over ``rows`` ((measured, how far behind the snout the artist put the head, that as a share
    of the way, its offset)), ``measured.thickness(share)`` the head's within the window ``share`` (a, the rows'
    least share; the skull rule's rounded as a template stores it): c the median distance in those thicknesses,
    k the ``FLOOR`` quantile of the shares, m the median offset; None with fewer than ``MIN_EXAMPLES`` thicknesses."""
    skulls = [behind / measured.thickness(share) for measured, behind, _, _ in rows if measured.thickness(share) > 0]
    if len(skulls) < MIN_EXAMPLES:
        return None
    return [float(np.median(skulls)), share, float(np.quantile([r[2] for r in rows], FLOOR)),
            float(np.median([r[3] for r in rows]))]


def learn_head(examples, per_example: np.ndarray, template) -> tuple[dict | None, int]:
    """({"skull": [c, a, k, m], "frame": [c, a, k, m, d]} or None, how many examples measured) over ``examples``
    (``learn.examples.Example``, their joints in the template frame ``per_example`` [N, J, 3]) that map the
    head. The skull rule: a, the least share of the way back from the snout to the front paws at which their
    artists put it (the window its thickness is read in); c, the median of its distance behind the snout in those
    thicknesses; k, the ``FLOOR`` quantile of those shares; m, the median of its height above the deepest point of
    its column, in that column's depths. Medians, so that one species' odd head (a giraffe's on its long neck)
    does not move every animal's. The frame rule (``learn_frame``) the same along the head's own path; left out
    when fewer than ``MIN_EXAMPLES`` paths were measured."""
    from .rump import measured_examples
    if JOINT not in template.names:
        return None, 0
    j = template.names.index(JOINT)
    rows, paths = [], []
    for truth, head in measured_examples(examples, per_example, template, JOINT, measure_head):
        section = head.column(float(truth[j, 2]))
        if section is not None:
            behind = head.tip - float(truth[j, 2])
            rows.append((head, behind, behind / (head.tip - head.paws), (truth[j, 1] - section[0]) / section[1]))
        if head.path is not None:
            paths.append((truth, head.path))
    skull = _medians(rows, round(float(min(r[2] for r in rows)), 4)) if len(rows) >= MIN_EXAMPLES else None
    if skull is None:
        return None, len(rows)
    skull = [round(v, 4) for v in skull]
    frame = learn_frame(paths, j)
    return {"skull": skull, **({"frame": frame} if frame is not None else {})}, len(rows)
