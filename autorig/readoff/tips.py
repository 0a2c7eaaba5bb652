"""Where a limb ends: tips read off the surface by a rule that moves little when the mesh moves little.

The embedding says which limb a tip belongs to (the sphere its reduced bone ends on); it does not say where on
that limb's end the tip goes well. Its end sphere is one of several small spheres packed greedily into the end
of a limb, and which of them is packed flips when the mesh moves by a millionth of its height: a head's end
sphere jumped from the crown to the face, a tail's from its tip to its middle (7-29 % of the height).

Here the tip is a continuous function of the surface:

1. ``reach(v)``: how far each surface vertex is from the body's core, measured along the surface: the
   geodesic (mesh-edge) distance from a virtual source joined to the vertices nearest the core's centre (the
   largest inscribed spheres'), each by how much farther it lies than the nearest (so a vertex entering
   that set enters at the reach it had). A minimum of continuous functions: continuous.
2. From the surface vertex nearest the embedding's end sphere, climb ``reach`` to its local maximum: the far
   end of that limb (a crown, a snout, a toe, a tail's tip). Any start in the limb climbs to the same end.
3. The tip is the centroid of the limb's cap around that end: the vertices connected to it whose reach is
   within ``CAP`` (a fraction of the height) of the end's, each weighed by its area and by how near the top
   of the cap it lies (a weight falling smoothly to 0 at the cap's edge). Two nearly equal maxima on a
   round crown share one cap, so the tip does not jump between them; a vertex entering the cap enters
   with weight 0.

A hand holding a spear or a sword: the weapon is a separate piece passing through the fist, and the arm's
path often ends in it (the medial spheres of the grip lie in the shaft). Climbed from there, the hand's tip
ran up the shaft to the weapon's far end, half the height past the hand, and the arm's joints, spread along
the path to that tip, put the wrist 15-18 % of the height off (re-posed 0 A.D. spearmen in a stride). A
separate piece shaped like a stick or a blade (``STICK``: its mean width, its area over pi times its length,
under a tenth of its length; the body's main piece never) is a held thing, not a limb's end, when the limb's
path reaches another piece close by (``HELD``): a paired limb's end (a hand, a foot) is climbed from that
other piece. A limb that is a stick of its own (a rod-like separate leg) keeps its piece: no other piece is
that near its path's end.
"""
from __future__ import annotations

import numpy as np

from ..input.facing import edge_graph, face_cross, unique_ints

CAP = 0.03    # the cap's depth, as a fraction of the height (the canonical frame is one unit tall)
NEAR = 0.02   # the source's reach: vertices this much farther from the core than the nearest one
PIECE = 0.1   # a piece whose box's diagonal is shorter than this (fraction of the height) holds no limb
PAIR = 0.1    # two ends within this of each other's mirror images are a mirrored pair (two ears, two horns)
STICK = 0.1   # a separate piece whose mean width (area / (pi * length)) is under this share of its length is a stick
HELD = 0.1    # a stick is held when another piece lies this near the limb's path's end (fraction of the height)
MIRROR = np.array([-1.0, 1.0, 1.0])
# A paired limb's end (a hand, a foot): the cap is taken around the highest top within a cap of the one the
# climb reached and no farther from it than this (a fraction of the height: a hand's fingertips), as a
# mid-plane part's is (``Surface._tip``). Which finger the climb reached flipped when the mesh moved a
# millionth (a MakeHuman body's left hand: the little finger or the middle one, its end 0.6 % of the height
# apart); a hand resting on a hip, climbed on without the bound, had gone on down the leg.
FINGERS = 0.05
# A paired limb's cap that holds a higher top farther than this from the one its climb reached (a fraction of the
# height: a hand's length) is no limb's end: the climb stopped on a bump on the way up another limb (a hand pressed
# into the hip, climbed from the hip: the cap was the thigh or the whole leg, its top 0.11-0.60 away), and no tip is
# read (``Surface.tip``). In the eleven posed rigs traced (scratch: the hands on hips and the raised and bent arms
# that a bound on the reach instead had moved), a hand's cap that reached a higher top beyond ``FINGERS`` (another
# finger, the other hand held against it) had it 0.052-0.073 away, one 0.106 (hands held together).
HAND = 0.1


class Surface:
    """A triangle surface's edge graph and reach from a core point, for reading tips off it."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, core: np.ndarray, edges: np.ndarray | None = None):
        from scipy.sparse import bmat, csr_matrix
        from scipy.sparse.csgraph import connected_components, dijkstra
        from scipy.spatial import cKDTree

        self.vertices = np.asarray(vertices, float)
        faces = np.asarray(faces, np.int64)
        V = len(self.vertices)
        self.graph = edge_graph(self.vertices, faces, edges)
        count, piece = connected_components(self.graph, directed=False)
        self.body = _body(self.vertices, faces, count, piece)
        # The virtual source (node V) is joined to the surface nearest the core: in each piece of the body, to
        # every vertex within NEAR of that piece's nearest one, by how much farther from the core than the
        # body's nearest it lies.
        straight = np.linalg.norm(self.vertices - np.asarray(core, float), axis=1)
        piece_nearest = np.full(count, np.inf)
        np.minimum.at(piece_nearest, piece[self.body], straight[self.body])
        near = np.flatnonzero(self.body & (straight <= piece_nearest[piece] + NEAR))
        source = csr_matrix((np.maximum(straight[near] - straight[self.body].min(), 1e-12),
                             (np.zeros(len(near), int), near)), shape=(1, V))
        with_source = bmat([[self.graph, csr_matrix((V, 1))], [source, csr_matrix((1, 1))]], format="csr")
        self.reach = dijkstra(with_source, indices=V)[:V]
        self.reach[~np.isfinite(self.reach)] = -np.inf    # vertices of no face, pieces too small for a limb
        self.top = _tops(self.graph, self.reach)
        self.area = np.bincount(faces.ravel(), weights=np.repeat(np.linalg.norm(face_cross(self.vertices, faces),
                                                                               axis=1) / 6.0, 3), minlength=V)
        self._used = np.flatnonzero(self.body)
        self._tree = cKDTree(self.vertices[self._used])
        sticks = _sticks(self.vertices, faces, self.body, count, piece)
        # The body without its sticks, where a paired limb's end is climbed from (None: there are no sticks).
        self._unheld = np.flatnonzero(self.body & ~sticks[piece]) if sticks.any() else None
        self._unheld_tree = cKDTree(self.vertices[self._unheld]) if self._unheld is not None and len(
            self._unheld) else None
        self._stick_vertex = sticks[piece]

    def tip(self, start: np.ndarray, cap: float = CAP, midline: bool = False) -> np.ndarray | None:
        """[3] the tip of the limb whose end lies nearest the point ``start`` [3]. midline: the tip of a part
        on the body's mid-plane (x = 0: a head, a tail), whose end may be a mirrored pair (two ears, two
        horns): the mean of the tips reached from ``start`` and from the mirror image of that tip when
        they are such a pair, so that which of the two the climb reaches does not matter. A paired limb's end (not
        ``midline``) is not climbed on a held stick (the module's last paragraph), and its cap is read around the
        highest top within ``FINGERS`` of the one its climb reached; None when its cap holds a higher top farther
        than ``HAND``: a hand pressed into the hip, the surface nearest its path's end the hip's, climbed to a bump
        there whose cap was the whole leg (its centroid put a MakeHuman body's hand end at its crotch, the wrists
        17 % of the height off). The limb then ends at its path's end."""
        start = np.asarray(start, float)
        if not midline:
            return self._tip(start, cap, unheld=True, highest=FINGERS)
        tip = self._tip(start, cap, highest=np.inf)
        # The other climb starts at the mirror image of the end the first reached, not of ``start``: a start on
        # the mid-plane is its own mirror image, and the surface nearest it either twin of a mirror pair as the
        # floats fell, so both climbs could reach the same horn, and the head's tip was that horn's instead of
        # the pair's middle (0 A.D.'s aurochs walking with its head low, ``benchmarks/stability.py --animal-poses``:
        # head_end 1.80 % of the height apart under 1e-6 noise).
        other = self._tip(tip * MIRROR, cap, highest=np.inf)
        # A mirrored pair when each is the other's mirror image: the other climb did not run off to another
        # part (a rhino's tail end is no mirror image of its horn).
        if np.linalg.norm(other * MIRROR - tip) <= PAIR:
            return 0.5 * (tip + other)
        return tip

    def _tip(self, start: np.ndarray, cap: float, unheld: bool = False, highest: float = 0.0) -> np.ndarray | None:
        from scipy.sparse.csgraph import connected_components

        _, i = self._tree.query(start)
        first = self._used[int(i)]
        if unheld and self._unheld_tree is not None and self._stick_vertex[first]:
            near, j = self._unheld_tree.query(start)
            if near <= HELD:
                first = self._unheld[int(j)]
        end = climbed = int(self.top[first])
        while True:
            # highest (a distance): where the cap around the climb's top reaches a higher top (a round head's
            # crown and the back of it, within CAP of each other), the cap is taken around the highest, whichever
            # the climb reached first (which flipped when the mesh moved a millionth: a re-posed CesiumMan's head,
            # 0.6 % of the height), if no farther than ``highest`` from the one climbed to: a mid-plane part's end
            # without bound, a paired limb's within ``FINGERS`` (a hand's other fingertips): a hand resting on a
            # hip, climbed on without the bound, went on down the leg (an earlier trial, ``benchmarks/poses.py
            # --all``: 486 -> 481 of 518).
            floor = self.reach[end] - cap
            inside = np.flatnonzero(self.reach > floor)
            sub = self.graph[inside][:, inside]
            _, label = connected_components(sub, directed=False)
            mine = inside[label == label[np.searchsorted(inside, end)]]
            top = int(mine[np.argmax(self.reach[mine])])
            if not highest or self.reach[top] <= self.reach[end]:
                break
            far = np.linalg.norm(self.vertices[top] - self.vertices[climbed])
            if far > highest:
                if far > HAND:
                    return None
                break
            end = top
        weight = self.area[mine] * ((self.reach[mine] - floor) / cap) ** 2
        if weight.sum() <= 0:
            return self.vertices[end].copy()
        return weight @ self.vertices[mine] / weight.sum()


def _body(vertices: np.ndarray, faces: np.ndarray, count: int, piece: np.ndarray) -> np.ndarray:
    """[V] bool: the vertices of the pieces (``count`` of them, ``piece`` [V] each vertex's) large enough to
    hold a limb (a box diagonal of at least PIECE: a separate head or leg, not a nail, an eye or a tooth); the
    largest piece when none is."""
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, piece[used], vertices[used])
    np.maximum.at(hi, piece[used], vertices[used])
    size = np.linalg.norm(hi - lo, axis=1)
    large = size >= PIECE
    if not large.any():
        large[np.argmax(size)] = True
    return used & large[piece]


def _sticks(vertices: np.ndarray, faces: np.ndarray, body: np.ndarray, count: int, piece: np.ndarray) -> np.ndarray:
    """[count] bool: the pieces of the body shaped like a stick or a blade (a spear, a sword, a staff): their
    mean width, their surface's area over pi times their length (a rod's diameter; a flat blade's 2 / pi of
    its width), under ``STICK`` of their length, the spread of their vertices along their longest principal
    direction. A crossguard or a spearhead widens a piece where it is, not along it. The body's largest piece
    (by vertices) is never one. The measures over the 0 A.D. bipeds' separate pieces (share of the length):
    spears 0.02-0.04, shields 0.11-0.19, forearm-and-hand pieces 0.18-0.20, heads 0.5-0.75."""
    out = np.zeros(count, bool)
    members = np.flatnonzero(body)
    if not len(members):
        return out
    sizes = np.bincount(piece[members], minlength=count)
    largest = int(np.argmax(sizes))
    area = np.bincount(piece[faces[:, 0]], weights=np.linalg.norm(face_cross(vertices, faces), axis=1) / 2.0,
                       minlength=count)
    order = members[np.argsort(piece[members], kind="stable")]
    bounds = np.searchsorted(piece[order], np.arange(count + 1))
    for p in np.flatnonzero(sizes >= 3):
        if p == largest:
            continue
        points = vertices[order[bounds[p]:bounds[p + 1]]]
        centred = points - points.mean(axis=0)
        _, _, axes = np.linalg.svd(centred, full_matrices=False)
        length = float(np.ptp(centred @ axes[0]))
        out[p] = area[p] < STICK * np.pi * length * length
    return out


def _tops(graph, reach: np.ndarray) -> np.ndarray:
    """[V] the local maximum of ``reach`` each vertex climbs to, always stepping to its highest neighbour."""
    graph = graph.tocsr()
    starts, neighbour = graph.indptr[:-1], graph.indices.astype(np.int64)
    has = np.flatnonzero(np.diff(graph.indptr) > 0)            # vertices with a neighbour
    row = np.repeat(np.arange(len(reach)), np.diff(graph.indptr))
    # each vertex's highest neighbour, the highest-numbered among equals: row by row reductions over the CSR
    # rows (a lexsort of every edge by vertex, reach and number did the same, 5x slower at 60k vertices)
    highest = np.full(len(reach), -np.inf)
    highest[has] = np.maximum.reduceat(reach[neighbour], starts[has])
    best = np.full(len(reach), -1, dtype=np.int64)
    best[has] = np.maximum.reduceat(np.where(reach[neighbour] == highest[row], neighbour, -1), starts[has])
    up = np.arange(len(reach))
    climbs = has[reach[best[has]] > reach[has]]
    up[climbs] = best[climbs]
    for _ in range(64):
        nxt = up[up]
        if np.array_equal(nxt, up):
            break
        up = nxt
    return up


def core_of(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """[3] the body's core: the centroid of the volume the surface encloses (its faces facing outward), a
    continuous function of the vertices (the largest inscribed sphere would sit in a large head)."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    total = volume.sum()
    if abs(total) <= 1e-12:
        return vertices[unique_ints(faces.ravel())].mean(axis=0)
    return ((a + b + c) / 4.0 * volume[:, None]).sum(axis=0) / total


def surface_for(field) -> Surface:
    """The ``Surface`` of the mesh a distance field was built on (its working copy), in the field's frame,
    with its reach measured from the volume's centroid."""
    vertices = field.surface_vertices
    surface = getattr(field, "base", field).surface
    return Surface(vertices, surface.faces, core_of(vertices, surface.faces), surface.edges())


def along_the_foot(joints: np.ndarray, template) -> np.ndarray:
    """[J, 3] ``joints`` (canonical frame, +y up) with each foot tip (a toe's or paw's end) at its joint's
    height, so that the bone runs along the ground: the end cap's centroid sits low in the toe, and a toe bone
    tipped down turns the foot when a motion's rest pose, whose feet are level, sets it level."""
    out = np.array(joints, float)
    for j in template.feet:
        j = int(j)
        p = int(template.parents[j])
        if p >= 0 and template.is_tip(j):
            out[j, 1] = out[p, 1]
    return out
