"""Legs read off the mesh: a four-legged template's leg joints placed where the animal's own legs put them.

The embedding and the placement put a leg's elbow, wrist and paw at the template's proportions along the
leg's path; a giraffe's wrist is not where a pig's is. The mesh says where the leg is: cut it by horizontal
planes and each leg is a ring of its own from the ground up to where it joins the body (the armpit or the
groin, ``free``), and the body rises above it to the back (``top``). Per leg, in the canonical frame (+y up,
one unit tall, facing +z):

    rings      the leg's cross-section at each level (``LEVELS``): its centre (the medial path) and its
               fore-aft and side widths (the thickness profile)
    free       the highest level up to which the leg's ring stands apart (neither across the mid-plane, nor
               reaching the other leg on the same side, nor buried in another part's section)
    top        the height of the back above the leg's top ring: the median, over ``TOP_RAYS`` vertical lines
               through the ring (its centre and a quarter width either way), of the highest surface crossing
               (a tail curled over the rump or a head raised over the shoulders crosses few of them; the
               highest vertex over the ring's box put a sheep's back 0.44 over its front legs and 1.00 over a
               tiger's rump)

and each of the leg's joints (root, elbow/knee, wrist/hock, paw) is placed by constants learned from rigged
animals (``autorig.learn.legs``), the same for every species:

    height     y_j = a_j * free + b_j * bend + c_j * (top - free)   (least squares over the examples; the
               shoulder and hip: free + c_j * (top - free), c_j the examples' median; the elbow: a_j * free,
               a_j the examples' median share, so that it stays within the leg's free part)
    across     (x, z)_j = centre(y_j) + offset_j * widths(y_j)   (medians over the examples; above ``free``
               the top ring's centre and widths, so the shoulder and hip sit over the leg's own column)

The leg's tip (``*_paw_end``) moves with its paw. A leg whose rings cannot be found (legs fused into a
skirt, a leg missing) keeps its joints. Only templates that carry learned ``legs`` run this stage.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LEVELS = np.linspace(0.005, 0.995, 100)
# The ring nearest where the rig has the leg is taken only this close (a fraction of the height): farther, the
# leg has no ring at that level.
NEAR = 0.08
BEND_FROM = 0.15
BEND_SOFT = 1e-3   # heights: rings this much less far aft than the farthest weigh 1/e in the bend (``bend``)
# The joints whose place along the body is each species' artists' habit rather than anatomy (issue 26's
# convention-free score: ``benchmarks/quadruped_score.py``): a rig is not wrong for putting them elsewhere on
# the body's line, so the confidence of a template with legs is calibrated on the other joints.
CONVENTION_JOINTS = ("hips", "spine", "chest", "neck")
FEATURES = 3
# A wrist's height is a share of the leg's free height learned from the foot's size (``foot_features``): its
# length fore and aft measured this high (a fraction of the height), against the leg's thinnest below
# THIN_SHARE of the free height; the share kept within the examples' ("range"; RATIO_RANGE without it): a
# cartoon cow's bulb of a hoof, 3.6 times the leg's thinnest, is no paw.
FOOT_FEATURES = 3
FOOT_LEVEL = 0.03
THIN_SHARE = 0.7
RATIO_RANGE = (0.05, 0.95)   # without the learned "range" (the least and the most share of the examples)
ABOVE_PAW = 0.08   # the wrist at least this share of the way from the paw up to the elbow (the examples: 0.09-0.69)
# The keys of the rules for joints read off the trunk rather than a leg, with their lengths: the rump's (tail
# base), the skull's (head) and the snout's (the head's rule before the skull's, still read).
READ_OFF = {"rump": 2, "skull": 4, "snout": 2, "frame": 5}   # "frame" only beside "skull" (``readoff.head``)
# Where ``top`` looks: vertical lines through the top ring's centre offset by these fractions of its widths.
TOP_RAYS = np.array([(dx, dz) for dx in (-0.25, 0.0, 0.25) for dz in (-0.25, 0.0, 0.25)])


@dataclass
class Leg:
    """One measured leg: joint indices ``chain`` [root, ..., paw, tip] of the template; ``side`` +1 left, -1
    right; ``levels`` [K] the heights with a ring, ``centres`` [K, 2] (x, z) and ``widths`` [K, 2] (x, z)
    of its rings; ``free`` and ``top`` heights."""
    chain: list[int]
    side: float
    levels: np.ndarray
    centres: np.ndarray
    widths: np.ndarray
    free: float
    top: float

    def across(self, y: float) -> tuple[np.ndarray, np.ndarray]:
        """(centre [2], widths [2]) of the leg at height ``y``: interpolated between its rings, the top
        ring's above ``free`` and the lowest ring's below it."""
        free = self.levels <= self.free + 1e-9
        levels, centres, widths = self.levels[free], self.centres[free], self.widths[free]
        centre = np.array([np.interp(y, levels, centres[:, k]) for k in range(2)])
        width = np.array([np.interp(y, levels, widths[:, k]) for k in range(2)])
        return centre, width


def legs_of(template) -> list[list[int]]:
    """Each leg's chain of joint indices [root, ..., foot tip], from the template's feet (``feet``) up to
    the last joint before the trunk (the first whose parent branches); a foot with fewer than two joints above
    it before the trunk has no leg to read."""
    children = template.children
    out = []
    for foot in template.feet:
        chain = [int(foot)]
        while template.parents[chain[-1]] >= 0 and len(children[template.parents[chain[-1]]]) == 1:
            chain.append(int(template.parents[chain[-1]]))
        if len(chain) >= 3:
            out.append(chain[::-1])
    return out


def sections(vertices: np.ndarray, faces: np.ndarray, levels: np.ndarray) -> list[np.ndarray]:
    """The mesh's cross-sections by the planes y = level: per level, the box [P, 4] (x min, x max, z min,
    z max) of each connected piece of the cut (an edge crossing the plane is a point; two points are joined
    when a triangle holds both edges; pieces of fewer than three points are left out)."""
    V = len(vertices)
    pairs = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    keys, of_face = np.unique(pairs[:, 0] * V + pairs[:, 1], return_inverse=True)
    of_face = of_face.reshape(3, -1).T
    a, b = vertices[keys // V], vertices[keys % V]
    below_a = a[None, :, 1] < levels[:, None]                        # [L, E]
    cross = below_a != (b[None, :, 1] < levels[:, None])
    level_of, edge_of = np.nonzero(cross)                            # the cut's points, level by level
    node = np.full(cross.shape, -1)
    node[level_of, edge_of] = np.arange(len(edge_of))
    crossing = cross[:, of_face]                                     # [L, F, 3]
    two = crossing.sum(axis=2) == 2
    lf, ff = np.nonzero(two)
    held = of_face[ff][crossing[lf, ff]].reshape(-1, 2)
    links = node[lf[:, None], held]                                  # [K, 2] points joined by a triangle
    label = _components(len(edge_of), links)
    t = (levels[level_of] - a[edge_of, 1]) / (b[edge_of, 1] - a[edge_of, 1])
    points = a[edge_of] + t[:, None] * (b[edge_of] - a[edge_of])
    pieces, first, count = np.unique(label, return_index=True, return_counts=True)
    box = np.full((len(pieces), 4), [np.inf, -np.inf, np.inf, -np.inf])
    at = np.searchsorted(pieces, label)
    np.minimum.at(box[:, 0], at, points[:, 0])
    np.maximum.at(box[:, 1], at, points[:, 0])
    np.minimum.at(box[:, 2], at, points[:, 2])
    np.maximum.at(box[:, 3], at, points[:, 2])
    keep = count >= 3
    piece_level = level_of[first]
    return [box[keep & (piece_level == k)] for k in range(len(levels))]


def _components(n: int, links: np.ndarray) -> np.ndarray:
    """[n] a label per node, equal within each connected component of the graph of ``links`` [K, 2]: every
    node hooked to its smallest neighbour's label, then labels followed to their roots, until nothing moves."""
    label = np.arange(n)
    if not len(links):
        return label
    while True:
        low = np.minimum(label[links[:, 0]], label[links[:, 1]])
        moved = label.copy()
        np.minimum.at(moved, label[links[:, 0]], low)
        np.minimum.at(moved, label[links[:, 1]], low)
        moved = moved[moved]
        while not np.array_equal(moved, moved[moved]):
            moved = moved[moved]
        if np.array_equal(moved, label):
            return label
        label = moved


def _along(chain_points: np.ndarray, y: float) -> np.ndarray:
    """(x, z) [2] where the polyline ``chain_points`` [C, 3] (root first) is at height ``y``: interpolated by
    height, the lowest joint's below it and the highest's above."""
    order = np.argsort(chain_points[:, 1], kind="stable")
    p = chain_points[order]
    return np.array([np.interp(y, p[:, 1], p[:, 0]), np.interp(y, p[:, 1], p[:, 2])])


def _box_distance(boxes: np.ndarray, point: np.ndarray) -> np.ndarray:
    """[P] distance in (x, z) from ``point`` [2] to each box [P, 4] (0 inside)."""
    dx = np.maximum(np.maximum(boxes[:, 0] - point[0], point[0] - boxes[:, 1]), 0.0)
    dz = np.maximum(np.maximum(boxes[:, 2] - point[1], point[1] - boxes[:, 3]), 0.0)
    return np.hypot(dx, dz)


def measure_legs(vertices: np.ndarray, faces: np.ndarray, joints: np.ndarray, template,
                 cut: list | None = None) -> list[Leg | None]:
    """Every leg of ``template`` (``legs_of``) measured on the mesh (``vertices`` [V, 3] canonical, ``faces``
    [F, 3]), found near where ``joints`` [J, 3] put it; None for a leg without a free ring. ``cut``: the
    mesh's ``sections`` at ``LEVELS``, when already made."""
    cut = sections(vertices, faces, LEVELS) if cut is None else cut
    chains = legs_of(template)
    out = []
    for chain in chains:
        side = 1.0 if joints[chain[0], 0] >= 0 else -1.0
        mates = [c for c in chains if c is not chain and (joints[c[0], 0] >= 0) == (side > 0)]
        mine = joints[chain[:-1]]
        rows = []                 # (level, centre x, centre z, width x, width z, free)
        for level, boxes in zip(LEVELS, cut):
            if not len(boxes):
                continue
            want = _along(mine, level)
            size = (boxes[:, 1] - boxes[:, 0]) + (boxes[:, 3] - boxes[:, 2])
            gap = _box_distance(boxes, want)
            k = int(np.argmin(gap + 1e-3 * size))
            if gap[k] > NEAR:
                continue
            box = boxes[k]
            others = [_along(joints[c[:-1]], level) for c in mates]
            buried = any((i != k and box[0] >= b[0] and box[1] <= b[1] and box[2] >= b[2] and box[3] <= b[3])
                         for i, b in enumerate(boxes))
            free = (min(side * box[0], side * box[1]) > 0 and not buried
                    and not any(box[2] <= o[1] <= box[3] for o in others))
            rows.append((level, (box[0] + box[1]) / 2, (box[2] + box[3]) / 2, box[1] - box[0], box[3] - box[2],
                         free))
        out.append(_leg(chain, side, rows, vertices, faces))
    return out


def highest_crossings(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """[P] the height of the highest point where the vertical line through each (x, z) of ``points`` [P, 2]
    meets the surface (``vertices`` [V, 3], ``faces`` [F, 3]); -inf where it misses."""
    corners = vertices[faces][:, :, [0, 2]]                          # [F, 3, 2]
    low, high = points.min(axis=0), points.max(axis=0)
    # Only the triangles whose box seen from above meets the points' box can be crossed (a leg's few).
    faces = faces[np.all(corners.min(axis=1) <= high, axis=1) & np.all(corners.max(axis=1) >= low, axis=1)]
    if not len(faces):
        return np.full(len(points), -np.inf)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    e1, e2 = (b - a)[:, [0, 2]], (c - a)[:, [0, 2]]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]                 # [F]
    flat = np.abs(det) < 1e-12                                       # seen edge-on from above
    det = np.where(flat, 1.0, det)
    q = points[:, None, :] - a[None, :, [0, 2]]                       # [P, F, 2]
    u = (q[..., 0] * e2[:, 1] - q[..., 1] * e2[:, 0]) / det
    v = (e1[:, 0] * q[..., 1] - e1[:, 1] * q[..., 0]) / det
    hit = ~flat & (u >= 0) & (v >= 0) & (u + v <= 1)
    y = a[:, 1] + u * (b[:, 1] - a[:, 1]) + v * (c[:, 1] - a[:, 1])
    return np.where(hit, y, -np.inf).max(axis=1)


def _leg(chain, side, rows, vertices, faces) -> Leg | None:
    """The ``Leg`` of the rings ``rows`` from the ground up (None when the lowest ring is not free)."""
    if not rows or not rows[0][5] or rows[0][0] > 0.1:
        return None
    run = 0
    while run + 1 < len(rows) and rows[run + 1][5]:
        run += 1
    table = np.array([r[:5] for r in rows], float)
    free = float(table[run, 0])
    centre, width = table[run, 1:3], table[run, 3:5]
    crossings = highest_crossings(vertices, faces, centre + TOP_RAYS * width)
    crossings = crossings[np.isfinite(crossings)]
    top = float(np.median(crossings)) if len(crossings) else free
    return Leg(chain=chain, side=side, levels=table[:run + 1, 0], centres=table[:run + 1, 1:3],
               widths=np.maximum(table[:run + 1, 3:5], 1e-6), free=free, top=max(top, free))


def bend(leg: Leg) -> float:
    """The height where the leg's medial path bends back most: its centre farthest aft of the straight line
    between its rings at ``BEND_FROM`` of ``free`` and at ``free`` (a hock points back; a knee forward), shared
    among the rings within ``BEND_SOFT`` as far aft."""
    keep = (leg.levels >= BEND_FROM * leg.free) & (leg.levels <= leg.free + 1e-9)
    if keep.sum() < 3:
        return BEND_FROM * leg.free
    y, z = leg.levels[keep], leg.centres[keep, 1]
    chord = z[0] + (z[-1] - z[0]) * (y - y[0]) / max(y[-1] - y[0], 1e-9)
    aft = z - chord
    # Not the level of the least: the levels weighed by how near the least each lies (within ``BEND_SOFT``), so
    # that rings aft by nearly the same share the bend instead of one taking it as the floats fall (0 A.D.'s
    # fox walking with its head low: a straight hind leg lifted off the ground, its rings aft by 1e-6 or less,
    # the bend 0.065 or 0.085 and the knee 1.6 % of the height apart under 1e-6 noise). The least of the levels
    # had also taken the lowest of rings exactly as far aft, as a straight edge of a low-poly leg cuts them;
    # with the ties shared (the hock and knee rules relearned) held-out animals' right rigs came out 0.04-0.05 %
    # of the height nearer on the mean in each pose (``benchmarks/animals.py --cv species,source``; at rest
    # 3.50 -> 3.46), held-out bears' swung hind hocks farther (12.7 -> 17.4 % walking). 1e-4: means 0.03-0.05
    # lower again, those hocks 18.8; 1e-5 still moves a straight leg of 60 rings' bend 1 % of the height under
    # the noise (``tests/test_legs.py``).
    weight = np.exp(-(aft - aft.min()) / BEND_SOFT)
    return float(weight @ y / weight.sum())


def joint_features(leg: Leg) -> np.ndarray:
    """[FEATURES] what a joint's height is learned from: (free, the bend's height, top - free)."""
    return np.array([leg.free, bend(leg), leg.top - leg.free])[:FEATURES]


def foot_features(leg: Leg) -> np.ndarray:
    """[FOOT_FEATURES] what a wrist's height is learned from, as a share of the leg's free height: (1, the
    foot's length fore and aft at ``FOOT_LEVEL`` over ``free``, that length over the leg's thinnest fore-aft
    width between ``FOOT_LEVEL`` and ``THIN_SHARE`` of ``free``). A hoof is short and no longer than the cannon
    above it, and the carpus sits half-way up an ungulate's leg; a paw is long, and the wrist sits just above it.
    The rings under ``FOOT_LEVEL`` are the sole's: a leg swung back (a walk) stands on the tip of its hoof, whose
    sliver at the ground read as the leg's thinnest (a fifth of the cannon), the hoof as a foot six times its
    leg and the wrist at the paw (``benchmarks/animals.py --poses walk``)."""
    levels, fore_aft = leg.levels, leg.widths[:, 1]
    foot = float(np.interp(FOOT_LEVEL, levels, fore_aft))
    low = (levels >= FOOT_LEVEL) & (levels <= THIN_SHARE * leg.free)
    thinnest = float(fore_aft[low].min() if low.any() else fore_aft.min())
    return np.array([1.0, foot / max(leg.free, 1e-6), foot / max(thinnest, 1e-6)])


def read_legs(joints: np.ndarray, template, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` (canonical frame) with each measured leg's joints placed by the template's learned
    ``legs`` ({joint name: {"height": [FEATURES] (optional: without it the joint keeps its height), "offset":
    [ox, oz]}}, ``autorig.learn.legs``); joints without a rule, and legs without, are left as they are."""
    model = template.legs
    if not model:
        return joints
    out = joints.copy()
    for leg in measure_legs(vertices, faces, joints, template):
        if leg is None:
            continue
        paw, tip = leg.chain[-2], leg.chain[-1]
        for j in leg.chain[:-1]:
            rule = model.get(template.names[j])
            if rule is None or "offset" not in rule:
                continue
            height, ratio = rule.get("height"), rule.get("ratio")
            if ratio is not None:
                # within the shares the examples had, and above the paw by a share of the way to the elbow
                share = float(np.clip(np.dot(ratio, foot_features(leg)), *rule.get("range", RATIO_RANGE)))
                elbow = float(joints[leg.chain[1], 1])
                y = max(leg.free * share, float(joints[paw, 1]) + ABOVE_PAW * max(elbow - float(joints[paw, 1]), 0.0))
            else:
                y = float(joints[j, 1]) if height is None else float(np.dot(height, joint_features(leg)))
            centre, width = leg.across(y)
            offset = np.array(rule["offset"], float) * [leg.side, 1.0]
            x, z = centre + offset * width
            out[j] = [x, y, z]
        out[tip] = out[paw] + (joints[tip] - joints[paw])
    return out


def limb_joints(template) -> np.ndarray:
    """[J] bool: the joints a four-legged rig is judged right or wrong by (all but ``CONVENTION_JOINTS``)."""
    return np.array([n not in CONVENTION_JOINTS for n in template.names])


def surface_of(field) -> tuple[np.ndarray, np.ndarray]:
    """(vertices [W, 3], faces [G, 3]) of the surface a distance field was built on (the working mesh, as it
    is or simplified: ``PreparedMesh.coarse``), in the field's frame: what the rig's legs are cut from, so
    that a dense scan costs no more to cut than the skeleton stages' copy."""
    return field.surface_vertices, getattr(field, "base", field).surface.faces


def parse_legs(value, names, bad) -> dict | None:
    """A template file's ``legs`` checked: {joint name: {"height": two numbers, "offset": two numbers}} for
    joints of the template (``names``), or None; ``bad(message)`` makes the error raised."""
    if value is None:
        return None
    def numbers(v, n=2):
        return (isinstance(v, list) and len(v) == n
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) and abs(x) < 100 for x in v))
    def rule(r):    # a leg joint's, the tail base's read off the rump (``readoff.rump``) or the head's (``.head``)
        return isinstance(r, dict) and (
            (set(r) <= set(READ_OFF) and (set(r) == {"skull", "frame"} or (len(r) == 1 and "frame" not in r))
             and all(numbers(v, READ_OFF[k]) for k, v in r.items()))
            or (not set(r) & set(READ_OFF) and ("height" not in r or numbers(r["height"], FEATURES))
                and ("ratio" not in r or numbers(r["ratio"], FOOT_FEATURES))
                and ("range" not in r or ("ratio" in r and numbers(r["range"]))) and numbers(r.get("offset"))))
    if not isinstance(value, dict) or not all(k in names and rule(r) for k, r in value.items()):
        raise bad(f'"legs" must map joint names to {{"height": {FEATURES} numbers (optional), "ratio": '
                  f'{FOOT_FEATURES} numbers and "range": [least, most] (optional), "offset": [x, z]}} '
                  'or {"rump": [k, m]} or {"skull": [c, a, k, m]} (and "frame": [c, a, k, m, d] or not) '
                  'or {"snout": [k, m]}')
    return {k: {key: [float(x) for x in r[key]] for key in r} if set(r) & set(READ_OFF) else
            {**({"height": [float(x) for x in r["height"]]} if "height" in r else {}),
             **({key: [float(x) for x in r[key]] for key in ("ratio", "range") if key in r}),
             "offset": [float(x) for x in r["offset"]]} for k, r in value.items()} or None

