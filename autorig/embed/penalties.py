"""Penalties of the discrete embedding, each vectorised over candidate spheres, with its weight.

An embedding puts every joint of the reduced skeleton on a sphere of the graph; a reduced bone runs along the
shortest graph path between its two spheres. Its cost is a weighted sum of the penalties below (all >= 0,
dimensionless). Baran & Popović learn their weights Γ from examples, and so does ``autorig learn``
(``autorig.learn.gamma``): a template's ``penalty_weights`` replace the hand-set defaults below, which were set
on the project's own mannequins and are what a template without learned weights uses.

=============  ======  ========================================================================================
penalty        weight  what it measures
=============  ======  ========================================================================================
length         1.0     log of (graph path length / template length), squared: bones keep their proportions
direction      0.8     1 - cos(angle) between the bone's straight-line direction and the template's; with the
                       template facing +z and its left at +x this also keeps left and right from swapping
feet           0.6     height of a foot joint above the lowest sphere, per 5% of the height: feet stand low
symmetry       0.6     mismatch of a mirrored pair: mirror image of one bone vs the other, and their path
                       lengths, relative to the bone length
backtrack      1.5     how much a bone's path doubles back toward its grandparent: d(g,p) + d(p,j) - d(g,j),
                       relative to the bone length
overlap        3.0     length of a bone's path shared with paths already placed, relative to the bone length:
                       limbs take disjoint routes (not counted near the parent joint, within the chain's first
                       template bone or 40% of the bone's length, where limbs leave the trunk together)
extremity      hard    leaf joints (tips) only at graph extremities (local maxima of the distance from the
                       graph's centre that stand out by 3% of the height)
fat            1.0     1 - radius / largest radius for joints the template calls fat (hips, chest), which
                       must moreover sit on spheres at least a quarter as wide as the largest
height         0       the root's and branch joints' height against the template's, squared, per 10% of the
                       height: a quadruped's chest sits high in the shoulders, not in the belly's thickest
                       sphere (off in the hand-set weights; ``autorig learn`` weighs it)
sides          0.5     which side of the body a foot's end lies on, against the joint its chain leaves the trunk
                       from (its parent: the hips, the chest): how far short of 2.5% of the height to its own
                       side, per 5% of the height (a lowered snout or a tail on the ground is no foot)
markers        4.0     only with ``--markers`` (``autorig.markers``): a marked joint's sphere's distance from its
                       marker, and a bone's detour from its path to pass the sphere nearest a marked joint
                       of its chain, beyond 5% of the height, per 5%: the limbs the markers are in
distinct       hard    no two joints on one sphere
=============  ======  ========================================================================================
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..discretize.graph import SphereGraph
from ..errors import RigFailedError
from ..template import PENALTY_WEIGHTS, ReducedSkeleton, Template

# The hand-set Γ of the table above. It lives with the template data (a template's ``penalty_weights`` are
# checked against its names), so that the template need not import the penalties that import it.
WEIGHTS = PENALTY_WEIGHTS
HEIGHT_UNIT = 0.1         # height (fraction of the figure) that costs one unit of the height penalty
FEET_UNIT = 0.05          # height (fraction of the figure) that costs one unit of the feet penalty
SHARED_FRACTION = 0.4     # paths may share spheres up to this fraction of the bone's length from its parent
PROMINENCE = 0.08         # how far (height units) a limb's end must stand out to count as an extremity
FAT_FRACTION = 0.25       # a fat joint's sphere is at least this fraction of the largest sphere's radius
SIDE_MARGIN = 0.025       # heights: a foot's end at least this far to its own side of its hips or chest
SIDE_UNIT = 0.05          # heights short of the margin that cost one unit of the sides penalty
MID_PLANE_X = 1e-6        # template units: a foot this near x = 0 has no side
MARKER_WEIGHT = 4.0       # per MARKER_UNIT of a marked joint's distance from its marker (``autorig.markers``)
MARKER_UNIT = 0.05        # beyond MARKER_FREE: the embedding chooses the limbs, the later stages place the
MARKER_FREE = 0.05        # joints within them (and put the marked ones at their markers)


@dataclass
class EmbeddingProblem:
    """Everything the search needs, precomputed.

    graph       the sphere graph
    reduced     the template's reduced skeleton (K joints)
    candidates  [K] arrays of the spheres each reduced joint may occupy
    bone_cost   [K] arrays [P_k, C_k]: cost of reduced bone k (length + direction + feet) with its parent
                on sphere candidates[parent][i] and k on sphere candidates[k][j]; None for the root. Only
                candidate pairs can be chosen, so nothing else is stored (the orientation search builds
                this problem in eight frames)
    bone_row    [K] arrays [S]: the row of bone_cost[k] for the parent on each sphere, -1 off its candidates
    root_cost   [S] cost of the root on each sphere (inf off its candidates)
    mirror      [K] reduced index of each joint's mirror image, -1 if none
    vectors     [K, 3] template vector of each reduced bone (parent to joint), zero for the root
    is_foot     [K] bool
    shared_ok   [K] how far (path length from the parent) a reduced bone may share spheres with other paths
    weights     {penalty: weight} (Γ): the template's learned ones, else ``WEIGHTS``
    fat         [K] bool, the joints the template calls fat
    heights     [K] template height of each reduced joint
    sides       [K] which side each reduced joint's sphere belongs on (``side_rules``)
    """
    graph: SphereGraph
    reduced: ReducedSkeleton
    candidates: list[np.ndarray]
    bone_cost: list
    bone_row: list
    root_cost: np.ndarray
    mirror: np.ndarray
    vectors: np.ndarray
    is_foot: np.ndarray
    shared_ok: np.ndarray
    weights: dict
    fat: np.ndarray
    heights: np.ndarray
    sides: np.ndarray


def graph_extremities(graph: SphereGraph, min_prominence: float = PROMINENCE) -> np.ndarray:
    """Indices of the spheres that end limbs: local maxima of the path distance from the graph's centre
    that stand out by at least ``min_prominence`` (height units); see ``prominences``."""
    return np.flatnonzero(prominences(graph) >= min_prominence)


def prominences(graph: SphereGraph) -> np.ndarray:
    """[S] how far each sphere stands out as the end of a limb (0 for spheres that are no local maximum).

    Spheres are ranked by path distance from the graph's centre; a local maximum's prominence is how far
    down one must go from it before a higher maximum can be reached (its persistence in the superlevel sets
    of the distance, found with union-find). A fingertip or the tip of a tail stands out by a limb's length;
    a bump on the side of a tail only by the bump's; the farthest sphere of all by infinity.
    """
    from_centre = graph.distances[int(np.argmin(graph.distances.max(axis=1)))]
    from_centre = np.where(np.isfinite(from_centre), from_centre, -1.0)
    if "limb_merges" not in graph.shared:
        graph.shared["limb_merges"] = _merges(from_centre, graph.neighbours())
    dying, merged_at, top = graph.shared["limb_merges"]
    prominence = np.zeros(len(from_centre))
    prominence[dying] = from_centre[dying] - from_centre[merged_at]
    prominence[top] = np.inf
    return prominence


def _merges(from_centre: np.ndarray, neighbours: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, int]:
    """The union-find sweep of ``prominences``: (dying [M] local maxima, merged_at [M] the sphere where each
    meets a higher one, top the highest). It depends only on the order of ``from_centre``, which the uniform
    scale of another frame keeps, so it is found once per graph."""
    order = np.argsort(-from_centre, kind="stable")
    root = np.full(len(order), -1)
    peak = np.zeros(len(order), dtype=np.int64)      # highest node of each component, kept at its root
    dying, merged_at = [], []

    def find(i):
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for v in order:
        root[v], peak[v] = v, v
        for w in neighbours[v]:
            if root[w] < 0:
                continue
            a, b = find(v), find(w)
            if a == b:
                continue
            # The component whose peak is lower dies here.
            low, high = (a, b) if from_centre[peak[a]] < from_centre[peak[b]] else (b, a)
            dying.append(peak[low])
            merged_at.append(v)
            root[low] = high
    return np.array(dying, dtype=np.int64), np.array(merged_at, dtype=np.int64), int(peak[find(order[0])])


def build_problem(graph: SphereGraph, template: Template, held=None) -> EmbeddingProblem:
    """The embedding problem of ``template`` on ``graph``; ``held``: joints the user marked
    (``autorig.markers.Held``, in the graph's frame), which the marker penalty keeps at their markers."""
    weights = dict(template.penalty_weights or WEIGHTS)
    reduced = template.reduced()
    K, S = len(reduced.joints), len(graph.radii)
    kids = [[] for _ in range(K)]
    for k, p in enumerate(reduced.parents):
        if p >= 0:
            kids[p].append(k)
    fat = set(template.fat)
    leaves = sum(1 for c in kids if not c)
    # A short limb (a stubby arm, a small tail) stands out less than the default; look harder before
    # concluding that the shape lacks the template's limbs.
    for prominence in (PROMINENCE, PROMINENCE / 2, PROMINENCE / 4, PROMINENCE / 8):
        ends = graph_extremities(graph, prominence)
        if len(ends) >= leaves:
            break
    else:
        raise RigFailedError(f"the {template.name} template needs {leaves} limb ends (head, hands, feet, "
                             f"tail...) but this shape has only {len(ends)}: is it the right template?")
    thick = np.flatnonzero(graph.radii >= FAT_FRACTION * graph.radii.max())
    thinness = weights["fat"] * thinness_of(graph)
    everything = np.arange(S)
    candidates = []
    for k, j in enumerate(reduced.joints):
        if not kids[k]:
            candidates.append(ends)
        elif j in fat:
            candidates.append(thick)
        else:
            candidates.append(everything)

    feet = set(template.feet)
    is_foot = np.array([j in feet for j in reduced.joints])
    feet_cost = weights["feet"] * feet_height(graph)
    sides = side_rules(template, reduced)

    tpos = template.positions[reduced.joints]
    vectors = bone_vectors(template, reduced)
    away = held.to_spheres(graph.centers) if held is not None else None   # [M, S] markers from spheres
    bone_cost, bone_row = [None] * K, [None] * K
    C, D = graph.centers, graph.distances
    for k in range(1, K):
        p = reduced.parents[k]
        # Only the parent's candidates by this joint's: a limb's end has a few dozen candidates, so most
        # bones cost |S| x ends, not |S|^2.
        rows, cols = candidates[p], candidates[k]
        path = D[np.ix_(rows, cols)]
        offset = C[cols][None, :, :] - C[rows][:, None, :]
        norm = np.linalg.norm(offset, axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            cost = weights["length"] * (np.log(np.maximum(path, 1e-9)) - np.log(reduced.lengths[k])) ** 2
            cos = np.where(norm > 0, (offset @ (vectors[k] / np.linalg.norm(vectors[k]))) / norm, -1.0)
        cost += weights["direction"] * (1.0 - cos)
        if is_foot[k]:
            cost += feet_cost[cols][None, :]
        if reduced.joints[k] in fat:
            cost += thinness[cols][None, :]
        if sides[k] and weights["sides"] > 0:
            cost += weights["sides"] * side_penalty(sides[k], C[rows, 0][:, None], C[cols, 0][None, :])
        if kids[k] and weights["height"] > 0:
            cost += weights["height"] * height_offset(graph, tpos[k, 1])[cols][None, :]
        if held is not None:
            cost += _marker_cost(held, graph, reduced.chains[k], rows, cols, away)
        cost[~np.isfinite(path)] = np.inf
        bone_cost[k] = cost
        bone_row[k] = np.full(S, -1, dtype=np.int64)
        bone_row[k][rows] = np.arange(len(rows))
    root_cost = np.full(S, np.inf)
    root_cost[candidates[0]] = thinness[candidates[0]] if reduced.joints[0] in fat else 0.0
    if weights["height"] > 0:
        root_cost[candidates[0]] += weights["height"] * height_offset(graph, tpos[0, 1])[candidates[0]]
    if held is not None and reduced.joints[0] in held.index[held.whole]:
        m = int(np.flatnonzero(held.index == reduced.joints[0])[0])
        root_cost[candidates[0]] += _beyond_free(away[m, candidates[0]] - away[m].min())

    names = [template.names[j] for j in reduced.joints]
    mirror_full = template.mirror_of()
    mirror = np.array([names.index(template.names[mirror_full[j]]) if template.names[mirror_full[j]] in names
                       and mirror_full[j] != j else -1 for j in reduced.joints])
    # Limbs leave the trunk together (a chest's neck and shoulders, a pelvis's two thighs) and part ways
    # within about the first bone and at the latest by the middle of the limb; two limbs that still share
    # spheres beyond that are one limb embedded twice.
    first_bone = np.array([0.0] + [float(np.linalg.norm(template.positions[c[1]] - template.positions[c[0]]))
                                   for c in reduced.chains[1:]])
    shared_ok = np.maximum(first_bone, SHARED_FRACTION * reduced.lengths)
    return EmbeddingProblem(graph, reduced, candidates, bone_cost, bone_row, root_cost, mirror, vectors,
                            is_foot, shared_ok, weights, np.array([j in fat for j in reduced.joints]), tpos[:, 1].copy(),
                            sides)


def side_rules(template: Template, reduced: ReducedSkeleton) -> np.ndarray:
    """[K] which side of the body each reduced joint's sphere belongs on, for the sides penalty: +1 or -1 a foot's
    end on the template's left (+x) or right, 0 any (the trunk's joints; a hand's end: hands meet in front of the
    chest; a head's or a tail's: an animal turns its head and swings its tail, the CyberWare horse's head 0.2 of
    its height to its side, and held to the mid-plane that frame cost more than one lying on its side)."""
    feet = set(template.feet)
    ends = set(range(len(reduced.joints))) - set(int(p) for p in reduced.parents if p >= 0)
    out = np.zeros(len(reduced.joints), dtype=np.int64)
    for k in ends:
        x = float(template.positions[reduced.joints[k], 0])
        if reduced.joints[k] in feet and abs(x) > MID_PLANE_X:
            out[k] = 1 if x > 0 else -1
    return out


def side_penalty(rule: int, parent_x, x):
    """The unweighted sides penalty of a foot's end on side ``rule`` (+1, -1: ``side_rules``) at ``x`` (an array)
    whose parent is at ``parent_x`` (broadcast against it): how far short of ``SIDE_MARGIN`` to its side of the
    parent it lies, per ``SIDE_UNIT``. Measured from the parent, not from x = 0: the orientation's frames are not
    yet centred on the mid-plane, and a limb leaves the trunk where the trunk is."""
    offset = np.asarray(x) - np.asarray(parent_x)
    return np.maximum(SIDE_MARGIN - rule * offset, 0.0) / SIDE_UNIT


def _marker_cost(held, graph: SphereGraph, chain: list[int], rows: np.ndarray, cols: np.ndarray,
                 away: np.ndarray) -> np.ndarray | float:
    """[P, C] the marker penalty of a reduced bone with its parent on spheres ``rows`` and its joint on ``cols``:
    its joint's sphere's distance from its marker (beyond the nearest sphere's), and for each marked joint
    inside its chain, the detour of the bone's path to pass that joint's nearest sphere (0 when the path goes
    through it). Only the markers
    that hold a joint whole: a chin, groin or withers says where along its limb a joint lies, not which limb."""
    cost = 0.0
    D = graph.distances
    for m, joint in enumerate(held.index):
        if not held.whole[m]:
            continue
        if joint == chain[-1]:
            cost = cost + _beyond_free(away[m, cols][None, :] - away[m].min())
        elif joint in chain[1:-1]:
            near = int(np.argmin(away[m]))
            detour = D[rows, near][:, None] + D[near, cols][None, :] - D[np.ix_(rows, cols)]
            cost = cost + _beyond_free(np.where(np.isfinite(detour), detour, np.inf))
    return cost


def _beyond_free(distance):
    """The marker penalty of a distance (height units) from a marker: MARKER_WEIGHT per MARKER_UNIT beyond
    MARKER_FREE."""
    return MARKER_WEIGHT * np.maximum(distance - MARKER_FREE, 0.0) / MARKER_UNIT


def height_offset(graph: SphereGraph, height: float) -> np.ndarray:
    """[S] the height penalty, on each sphere, of a joint whose template height is ``height``."""
    return ((graph.centers[:, 1] - height) / HEIGHT_UNIT) ** 2


def thinness_of(graph: SphereGraph) -> np.ndarray:
    """[S] the fat penalty of a fat joint on each sphere: 1 - radius / largest radius."""
    return 1.0 - graph.radii / graph.radii.max()


def feet_height(graph: SphereGraph) -> np.ndarray:
    """[S] the feet penalty of a foot joint on each sphere: its height above the lowest, per FEET_UNIT."""
    return (graph.centers[:, 1] - graph.centers[:, 1].min()) / FEET_UNIT


def bone_vectors(template: Template, reduced: ReducedSkeleton) -> np.ndarray:
    """[K, 3] the template's vector of each reduced bone, parent to joint (zero for the root)."""
    tpos = template.positions[reduced.joints]
    vectors = np.zeros((len(reduced.joints), 3))
    for k in range(1, len(reduced.joints)):
        vectors[k] = tpos[k] - tpos[reduced.parents[k]]
    return vectors


def direction_term(centers: np.ndarray, spheres, parents: np.ndarray, vectors: np.ndarray) -> float:
    """The unweighted direction penalty of an embedding placing reduced joint k on ``spheres[k]``: the sum over
    its bones of 1 - cos(angle) between the bone's straight line and the template's ``vectors`` [K, 3]."""
    total = 0.0
    for k in range(1, len(spheres)):
        offset = centers[spheres[k]] - centers[spheres[parents[k]]]
        direction = vectors[k] / np.linalg.norm(vectors[k])
        norm = float(np.linalg.norm(offset))
        total += 1.0 - (float(offset @ direction) / norm if norm > 0 else -1.0)
    return total


def embedding_terms(problem: EmbeddingProblem, spheres) -> dict[str, float]:
    """{penalty: unweighted value} of the complete embedding placing reduced joint k on ``spheres[k]``:
    the cost the search gives it is the sum of ``problem.weights[p] * value`` (the learner's features)."""
    spheres = [int(s) for s in spheres]
    graph, reduced = problem.graph, problem.reduced
    C, D, parents = graph.centers, graph.distances, reduced.parents
    thin = thinness_of(graph)
    feet = feet_height(graph)
    unit = {name: 1.0 for name in problem.weights}
    terms = dict.fromkeys(problem.weights, 0.0)
    terms["fat"] += float(thin[spheres[0]]) if problem.fat[0] else 0.0
    has_children = np.zeros(len(spheres), dtype=bool)
    has_children[parents[parents >= 0]] = True
    for k in np.flatnonzero(has_children):
        terms["height"] += float(height_offset(graph, problem.heights[k])[spheres[k]])
    terms["direction"] = direction_term(C, spheres, parents, problem.vectors)
    used = np.zeros(len(graph.radii), dtype=bool)
    for k in range(1, len(spheres)):
        p, s, u = parents[k], spheres[k], spheres[parents[k]]
        terms["length"] += float((np.log(max(D[u, s], 1e-9)) - np.log(reduced.lengths[k])) ** 2)
        if problem.is_foot[k]:
            terms["feet"] += float(feet[s])
        if problem.sides[k]:
            terms["sides"] += float(side_penalty(int(problem.sides[k]), C[u, 0], C[s, 0]))
        if problem.fat[k]:
            terms["fat"] += float(thin[s])
        target = np.array([s])
        if parents[p] >= 0:
            terms["backtrack"] += float(backtrack_penalty(problem, k, spheres[parents[p]], u, target, unit)[0])
        mirror = problem.mirror[k]
        if 0 <= mirror < k:
            terms["symmetry"] += float(symmetry_penalty(problem, k, u, target, spheres[mirror],
                                                        spheres[parents[mirror]], unit)[0])
        if k > 1:
            used[graph.path(spheres[parents[k - 1]], spheres[k - 1])] = True
            here = used & (D[u] > problem.shared_ok[k])
            terms["overlap"] += float(overlap_penalty(problem, k, u, here, target, unit)[0])
    return terms



def symmetry_penalty(problem: EmbeddingProblem, k: int, parent_sphere: int, spheres: np.ndarray,
                     mirror_sphere: int, mirror_parent_sphere: int, weights: dict | None = None) -> np.ndarray:
    """[N] penalty for placing joint k on each of ``spheres`` when its mirror image is already placed."""
    C, D = problem.graph.centers, problem.graph.distances
    flip = np.array([-1.0, 1.0, 1.0])
    mine = (C[spheres] - C[parent_sphere]) * flip
    theirs = C[mirror_sphere] - C[mirror_parent_sphere]
    length = problem.reduced.lengths[k]
    shape = np.linalg.norm(mine - theirs, axis=1) / length
    lengths = np.abs(D[parent_sphere, spheres] - D[mirror_parent_sphere, mirror_sphere]) / length
    return (weights or problem.weights)["symmetry"] * (shape + lengths)


def backtrack_penalty(problem: EmbeddingProblem, k: int, grandparent_sphere: int, parent_sphere: int,
                      spheres: np.ndarray, weights: dict | None = None) -> np.ndarray:
    """[N] penalty for a bone whose path turns back toward the grandparent joint."""
    D = problem.graph.distances
    detour = D[grandparent_sphere, parent_sphere] + D[parent_sphere, spheres] - D[grandparent_sphere, spheres]
    return (weights or problem.weights)["backtrack"] * np.maximum(detour, 0.0) / problem.reduced.lengths[k]


def shared_length(graph: SphereGraph, source: int, used: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """[N] for each of ``spheres`` [N], the length of the shortest path source -> sphere that runs over
    ``used`` spheres ([S] bool): the sum, over the path's edges, of the edge's length when its far end is used.

    A used sphere w adds its incoming edge to the paths of exactly the spheres in its subtree of the
    shortest-path tree, which the tree's depth-first ranges tell without walking any path (the search calls
    this for every state it expands).
    """
    far_ends = np.flatnonzero(used)
    far_ends = far_ends[far_ends != source]
    if len(far_ends) == 0:
        return np.zeros(len(spheres))
    parent, first, end = graph.path_tree(source)
    own = np.linalg.norm(graph.centers[far_ends] - graph.centers[parent[far_ends]], axis=1)
    position = first[spheres]
    below = (first[far_ends, None] <= position[None, :]) & (position[None, :] < end[far_ends, None])
    return (own[:, None] * below).sum(axis=0)


def overlap_penalty(problem: EmbeddingProblem, k: int, parent_sphere: int, used: np.ndarray,
                    spheres: np.ndarray, weights: dict | None = None) -> np.ndarray:
    """[N] penalty: length of the path parent -> sphere that runs over ``used`` spheres ([S] bool, the
    spheres on the paths already placed, the parent's own sphere excluded)."""
    shared = shared_length(problem.graph, parent_sphere, used, spheres)
    return (weights or problem.weights)["overlap"] * shared / problem.reduced.lengths[k]
