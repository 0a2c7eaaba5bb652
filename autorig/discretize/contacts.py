"""Contacts: the sphere graph's edges between parts of the body that only touch (``autorig.discretize.graph``).

Where two parts of the body touch (hands meeting in front of the chest, an arm resting on a thigh), the inside
runs from one into the other, and so would the graph: two hands that meet became one limb end, and the second
hand's chain went to the top of the head (posed corpus bipeds with their arms bent: wrists 15-20 % of the
height off). A contact shows in the mesh itself: the segment between the two spheres passes close to the
surface (its least depth under ``PINCH`` of the smaller radius, where a limb's own segments stay about a
radius deep), and the surface points nearest the two spheres, on one connected piece of the mesh, are far
apart over the surface (more than ``CONTACT_RATIO`` times the spheres' span, the centres' distance plus both
radii) though near in space. Such edges are cut (``_contacts``). The surface distance is measured along the
mesh's edges (Dijkstra, bounded at the span's multiple): a limb's own pinch (a wrist, a thin waist) keeps its
edges, since around it the surface is as short as through it.

Where one part presses into the other (a hand pressed into a hip, the hands on the thighs of a seated figure,
two hands round a weapon's shaft), the surfaces interpenetrate: spheres inside both parts take the hand's
surface as their nearest, segments there stay deep, and a few unpinched edges (some to the trunk's widest
spheres, whose spans exceed ``CONTACT_SPAN``) carried the hand's chain into the hip. So around each contact
found, the edges between spheres next to a cut edge are checked again without the pinch (a least depth under
``NEAR_PINCH`` of the smaller radius) up to ``NEAR_SPAN``, their limit widened by the way from each nearest
point to the vertex it is measured from (a low-poly box figure's corners lie far from its nearest points). Of
those whose surfaces are as far apart, only the ones that close a loop longer than ``LOOP`` through the body
are cut, as between pieces (``_piece_contacts``): a raised arm whose box interpenetrates the torso's at the
shoulder keeps its attachment, since without those edges nothing else joins it.

A hand pressed into a hip away from any such contact (the arms akimbo) shows no pinch at all: the spheres where
the two interpenetrate join hand and hip with deep segments, and the hand, joined to the trunk, was no end of
the shape (posed corpus bipeds with their hands on their hips: 10 of 74 with an arm's chain at the shoulder).
There the surface tells still: the hand's surface and the hip's are far apart over it (round by the arm and
the shoulder). Measuring that for every edge would take a walk over the surface from each sphere, so it is
bounded from below instead (``_pressed_contacts``): from ``LANDMARKS`` points far out on the surface (the ends of
the limbs, each the farthest over the surface from those before), |d(L, a) - d(L, b)| for a landmark L is at most
the surface distance between a and b. An edge less deep than ``NEAR_PINCH`` of its smaller radius, spanning at
most ``NEAR_SPAN``, whose nearest surface points that bound puts farther apart than ``CONTACT_RATIO`` times the
span (as for a pinched edge), is a contact when it closes a loop longer than ``LOOP`` (``_piece_contacts``).
A medial sphere touches the surface on two sides at once, equally near, and a sphere inside both the hand and the
hip touches one on each: which of them its nearest point is, is a rounding error's choice, and it decided on
which side of the contact the sphere's edges were cut (a posed MakeHuman body's hand moved 3 % of the height
under noise of 1e-6 of it). So each sphere is read on both sides (``_far_side_corners``: the nearest point seen
from ``FAR_SIDE`` of its radius beyond its centre, away from its nearest point) and an edge's bound is the largest
between either side of one sphere and either side of the other: such a sphere's edges to both parts are
candidates, and the order of ``_piece_contacts`` keeps the one that joins it first. A limb's sphere touches its
front and back, which are no farther apart over the surface than round the limb.

Between separate pieces of the mesh (a sword in a hand, a separate head, a game character's forearm-and-hand
pieces) the junctions are mostly pinched and the surface cannot tell anything: there the graph itself does
(``_piece_contacts``). The pinched edges between pieces are taken in the order of their distance from the
body's middle (along the graph, from its widest sphere), each kept when it joins what is not yet joined (a
piece's attachment: a head on its neck, an arm at its shoulder, a sword in its fist) or what is joined within
``LOOP`` of the height anyway (the seams around that attachment: 0.12-0.27 on 0 A.D.'s bipeds), and cut when
it would close a longer loop: two hands that meet in front of the chest, each on its own arm's piece, are
joined already through both arms and the shoulders (0.8-0.9 of the height on 0 A.D.'s Iberian spearman), and
with the edge kept the two hands made one limb end and both arm chains went to the corners of the tunic.
A hand on a piece of its own pressed into the hip is no pinch either: there the unpinched edges between pieces
(less deep than ``NEAR_PINCH`` of the smaller radius, spanning at most ``NEAR_SPAN``) are taken too, and the
order puts first the edges that hold a piece's attachment (``_rim_first``): a game character's limb piece is
open where it is hidden inside the body it hangs from (0 A.D.'s arms at the shoulder), and its hand, nearer the
body's middle than its shoulder when pressed into the hip, was kept as the arm's attachment and the shoulder cut
(0 A.D.'s Iberian spearman, hands on hips: both wrists 18 % of the height off, confidence 0.75). An edge whose
sphere on the smaller of its two pieces lies within ``RIM_REACH`` of its radius from that piece's open rim goes
first.
"""
from __future__ import annotations

import numpy as np

from ..input.facing import _boundary_half_edges, face_cross, unique_ints
from .distance import DistanceField

PINCH = 0.5          # a segment whose least depth is under this fraction of the smaller radius may cross a contact
CONTACT_RATIO = 3.0  # surface distance over the spheres' span beyond which a pinched edge is a contact
CONTACT_SPAN = 0.12  # heights: spans above this are not checked (bounds the Dijkstra; limbs touch at smaller ones)
NEAR_PINCH = 1.0     # next to a cut edge, a segment less deep than the smaller radius may cross the same contact
NEAR_SPAN = 0.3      # heights: ... up to this span (the widest trunk spheres' edges to a limb: 0.16-0.17)
LOOP = 0.4           # heights: a pinched edge between two pieces closing a longer loop is a contact
RIM_REACH = 2.0      # radii: a sphere this near its piece's open rim holds the piece's attachment (``_rim_first``)
LANDMARKS = 8        # points far out on the surface whose distances bound a contact's (``_pressed_contacts``)
FAR_SIDE = 0.5       # radii: a sphere's far side is read from this far off its centre (``_far_side_corners``)


def _contacts(field: DistanceField, c: np.ndarray, r: np.ndarray, pairs: np.ndarray,
              samples: int = 9) -> np.ndarray:
    """[E] bool: which edges ``pairs`` [E, 2] of spheres (centres ``c``, radii ``r``, in the field's frame, one
    unit a height) join two parts of the body that only touch (the module's docstring)."""
    out = np.zeros(len(pairs), dtype=bool)
    if not len(pairs):
        return out
    i, j = pairs[:, 0], pairs[:, 1]
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    points = c[i][:, None, :] * (1 - t) + c[j][:, None, :] * t
    least = field.depth(points.reshape(-1, 3)).reshape(len(pairs), samples).min(axis=1)
    span = np.linalg.norm(c[i] - c[j], axis=1) + r[i] + r[j]
    pinched = (least < PINCH * np.minimum(r[i], r[j])) & (span <= CONTACT_SPAN)
    check = np.flatnonzero(pinched)
    surface = field.surface
    mesh, piece = _surface_pieces(surface)
    vertex, offset = _nearest_corners(surface, c, unique_ints(pairs[check].ravel()))

    def read(edges: np.ndarray) -> None:
        """Fill ``vertex`` and ``offset`` in for the spheres of ``edges`` not read yet."""
        todo = unique_ints(pairs[edges].ravel())
        todo = todo[vertex[todo] < 0]
        more_vertex, more_offset = _nearest_corners(surface, c, todo)
        vertex[todo], offset[todo] = more_vertex[todo], more_offset[todo]

    a, b = vertex[i[check]], vertex[j[check]]
    between = check[piece[a] != piece[b]]
    on_one = (piece[a] == piece[b]) & (a != b)
    check, a, b = check[on_one], a[on_one], b[on_one]
    if len(check):
        out[check[_surface_far(mesh, a, b, CONTACT_RATIO * span[check])]] = True
    if out.any():
        # Around each contact: the edges between spheres next to a cut one, unpinched (the module's docstring).
        touched = np.zeros(len(c), dtype=bool)
        touched[pairs[out].ravel()] = True
        beside = touched.copy()
        beside[i[touched[j]]] = True
        beside[j[touched[i]]] = True
        again = np.flatnonzero(beside[i] & beside[j] & ~out & (least < NEAR_PINCH * np.minimum(r[i], r[j]))
                               & (span <= NEAR_SPAN))
        read(again)
        a, b = vertex[i[again]], vertex[j[again]]
        on_one = (piece[a] == piece[b]) & (a != b)
        again, a, b = again[on_one], a[on_one], b[on_one]
        if len(again):
            far = again[_surface_far(mesh, a, b, CONTACT_RATIO * span[again] + offset[i[again]] + offset[j[again]])]
            if len(far):
                out[_piece_contacts(c, r, pairs, far, out)] = True
    # Unpinched edges between pieces (a hand on a piece of its own pressed into the hip): cut as pinched ones
    # are, the pieces' attachments at their open rims taken first (``_rim_first``).
    near = (least < NEAR_PINCH * np.minimum(r[i], r[j])) & (span <= NEAR_SPAN)
    loose = np.flatnonzero(~out & ~pinched & near)
    read(loose)
    loose = loose[piece[vertex[i[loose]]] != piece[vertex[j[loose]]]]
    if len(between) or len(loose):
        between = np.concatenate([between, loose])
        first = _rim_first(surface, piece, vertex, c, r, pairs[between])
        out[_piece_contacts(c, r, pairs, between, out, first)] = True
    # Unpinched contacts on one piece (a hand pressed into the hip), by the landmarks' bound.
    pressed = np.flatnonzero(~out & near)
    read(pressed)
    out[_pressed_contacts(surface, mesh, piece, vertex, offset, c, r, pairs, pressed, span, out)] = True
    return out


def _pressed_contacts(surface, mesh, piece: np.ndarray, vertex: np.ndarray, offset: np.ndarray, c: np.ndarray,
                      r: np.ndarray, pairs: np.ndarray, check: np.ndarray, span: np.ndarray, cut: np.ndarray
                      ) -> np.ndarray:
    """Indices into ``pairs`` [E, 2] of the contacts no pinch shows (the module's docstring): of the edges
    ``check`` (indices; spanning ``span`` [E]), those whose spheres' nearest surface corners (``vertex`` [S], at
    ``offset`` [S] from the nearest points) lie on one piece of the mesh (``mesh``, ``piece``: ``_surface_pieces``)
    and farther apart over it than ``CONTACT_RATIO`` times the span by the landmarks' bound (the largest between
    either side of one sphere and either side of the other, ``_far_side_corners``), and that close a loop longer
    than ``LOOP`` through the body (``_piece_contacts``; ``cut`` [E] the edges cut already)."""
    i, j = pairs[:, 0], pairs[:, 1]
    a, b = vertex[i[check]], vertex[j[check]]
    same = (piece[a] == piece[b]) & (a != b)
    check, a, b = check[same], a[same], b[same]
    # Each sphere touches the surface on two sides (a medial sphere's nearest points tie): the far side's too.
    other, gap = _far_side_corners(surface, c, r, vertex, unique_ints(pairs[check].ravel()))
    both = (mesh + mesh.T).tocsr()
    bound = np.zeros(len(check))
    for part in unique_ints(piece[a]):
        mine = np.flatnonzero(piece[a] == part)
        reach = _landmark_distances(both, surface.vertices, np.flatnonzero(piece == part))
        for x in (a[mine], other[i[check[mine]]]):
            for y in (b[mine], other[j[check[mine]]]):
                on = (piece[x] == part) & (piece[y] == part)     # a far side on another piece: no bound
                apart = np.zeros(len(x))
                apart[on] = np.abs(reach[:, x[on]] - reach[:, y[on]]).max(axis=0)
                bound[mine] = np.maximum(bound[mine], apart)
    limit = (CONTACT_RATIO * span[check] + np.maximum(offset[i[check]], gap[i[check]])
             + np.maximum(offset[j[check]], gap[j[check]]))
    far = check[bound > limit]
    if not len(far):
        return np.zeros(0, dtype=np.int64)
    return _piece_contacts(c, r, pairs, far, cut)


def _landmark_distances(both, vertices: np.ndarray, members: np.ndarray) -> np.ndarray:
    """[LANDMARKS, V] distances over the surface (``both``: its edge graph, each edge both ways) from landmarks
    spread over one piece of it (``members``, its vertices), each the farthest from those before it, the first
    the farthest from the piece's mean: the ends of the shape's limbs (feet, hands, the head), whose distances
    tell apart two points near in space that lie on different limbs. |d(L, a) - d(L, b)| <= d(a, b) for any
    landmark L, so their largest is a lower bound of the distance between a and b over the surface."""
    from scipy.sparse.csgraph import dijkstra

    centre = vertices[members].mean(axis=0)
    mark = int(members[np.argmax(np.linalg.norm(vertices[members] - centre, axis=1))])
    rows, least = [], None
    for _ in range(LANDMARKS):
        row = dijkstra(both, directed=True, indices=mark)
        rows.append(row)
        least = row if least is None else np.minimum(least, row)
        mark = int(members[np.argmax(least[members])])
    return np.array(rows)


def _nearest_corners(surface, c: np.ndarray, spheres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """([S] vertex, [S] gap): for each of ``spheres`` (indices into the centres ``c`` [S, 3]), the corner of the
    triangle holding its nearest surface point that lies nearest that point, and how far from it (-1 and 0 for
    the other spheres)."""
    vertex = np.full(len(c), -1, dtype=np.int64)
    gap = np.zeros(len(c))
    if len(spheres):
        near = surface.nearest(c[spheres])
        corner = surface.faces[surface.nearest_faces(near)]
        gaps = np.linalg.norm(surface.vertices[corner] - near[:, None, :], axis=2)
        vertex[spheres] = corner[np.arange(len(spheres)), np.argmin(gaps, axis=1)]
        gap[spheres] = gaps.min(axis=1)
    return vertex, gap


def _far_side_corners(surface, c: np.ndarray, r: np.ndarray, vertex: np.ndarray, spheres: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """([S] vertex, [S] gap) as ``_nearest_corners`` gives them, for each of ``spheres``' far side: the corner
    nearest the surface point nearest a point ``FAR_SIDE`` of its radius from its centre, away from its nearest
    point. A medial sphere touches the surface at two points or more, equally near; which one its nearest point
    is, is a rounding error's choice (a sphere inside both a hand and the hip it presses into touches both), and
    the far side reads the other. For the other spheres (and those whose nearest corner is unread, ``vertex``
    -1), ``vertex``'s own corner and 0."""
    out = vertex.copy()
    gap = np.zeros(len(c))
    spheres = spheres[vertex[spheres] >= 0]
    if len(spheres):
        near = surface.nearest(c[spheres])
        away = c[spheres] - near
        away /= np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-12)
        moved = c[spheres] + FAR_SIDE * r[spheres, None] * away
        corner, gaps = _nearest_corners(surface, moved, np.arange(len(spheres)))
        out[spheres], gap[spheres] = corner, gaps
    return out, gap


def _surface_far(mesh, a: np.ndarray, b: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """[N] bool: which surface vertices ``a`` [N] lie farther than ``limit`` [N] from ``b`` [N] over the surface
    (``mesh``: its edges' lengths, each edge once)."""
    from scipy.sparse.csgraph import dijkstra

    # Each source's walk bounded at its own pairs' largest limit, not all at the largest of all: the walk's cost
    # goes as the surface within the bound (the distances within it are the same either way, those beyond it
    # are beyond every limit they are compared with).
    # Both directions of each edge stored once (the same graph): an undirected walk transposes the whole mesh's
    # matrix again on every call (60k faces: 33 walks, 0.01 s of transposes).
    both = (mesh + mesh.T).tocsr()
    far = np.zeros(len(a), dtype=bool)
    for source in unique_ints(a):
        mine = np.flatnonzero(a == source)
        reach = dijkstra(both, directed=True, indices=int(source), limit=float(limit[mine].max()))
        far[mine] = reach[b[mine]] > limit[mine]
    return far


def _rim_first(surface, piece: np.ndarray, vertex: np.ndarray, c: np.ndarray, r: np.ndarray,
               edges: np.ndarray) -> np.ndarray:
    """[N] bool: which of ``edges`` [N, 2] (sphere pairs whose nearest surface corners, ``vertex`` [S], lie on two
    different pieces of the mesh, ``piece`` [V]) hold an attachment: the sphere on the smaller piece (by its
    area) lies within ``RIM_REACH`` of its radius from that piece's open rim (the module's docstring)."""
    from scipy.spatial import cKDTree

    faces = surface.faces
    tails, heads = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    lone = _boundary_half_edges(tails, heads)
    rim = np.zeros(len(surface.vertices), dtype=bool)
    rim[tails[lone]] = rim[heads[lone]] = True
    area = np.linalg.norm(face_cross(surface.vertices, faces), axis=1)
    size = np.bincount(piece[faces[:, 0]], weights=area, minlength=piece.max() + 1)
    a, b = edges[:, 0], edges[:, 1]
    pa, pb = piece[vertex[a]], piece[vertex[b]]
    small = np.where(size[pa] < size[pb], a, b)
    part = np.where(size[pa] < size[pb], pa, pb)
    out = np.zeros(len(edges), dtype=bool)
    for p in unique_ints(part):
        ring = np.flatnonzero(rim & (piece == p))
        if len(ring):
            mine = np.flatnonzero(part == p)
            gap, _ = cKDTree(surface.vertices[ring]).query(c[small[mine]])
            out[mine] = gap < RIM_REACH * r[small[mine]]
    return out


def _piece_contacts(c: np.ndarray, r: np.ndarray, pairs: np.ndarray, between: np.ndarray,
                    cut: np.ndarray, first: np.ndarray | None = None) -> np.ndarray:
    """Indices into ``pairs`` [E, 2] of the edges among ``between`` (edges whose spheres are nearest two different
    pieces of the mesh, or that the surface found far apart) that are contacts (the module's docstring), ``cut``
    [E] the edges cut already; ``first`` [len(between)] bool: the edges taken before the others (``_rim_first``),
    each group in the order of its distance from the body's middle."""
    import heapq

    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    n = len(r)
    i, j = pairs[:, 0], pairs[:, 1]
    length = np.linalg.norm(c[i] - c[j], axis=1)
    live = ~cut
    middle = dijkstra(coo_matrix((length[live], (i[live], j[live])), shape=(n, n)).tocsr(), directed=False,
                      indices=int(np.argmax(r)))
    fixed = live.copy()
    fixed[between] = False
    root = list(range(n))

    def find(x: int) -> int:
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    near: list[list[tuple[int, float]]] = [[] for _ in range(n)]

    def join(e: int) -> None:
        a, b, d = int(i[e]), int(j[e]), float(length[e])
        near[a].append((b, d))
        near[b].append((a, d))
        root[find(a)] = find(b)

    def within(a: int, b: int) -> bool:
        """Whether the edges joined so far lead from a to b within LOOP."""
        best, heap = {a: 0.0}, [(0.0, a)]
        while heap:
            d, x = heapq.heappop(heap)
            if x == b:
                return True
            if d > best[x]:
                continue
            for y, step in near[x]:
                e = d + step
                if e <= LOOP and e < best.get(y, np.inf):
                    best[y] = e
                    heapq.heappush(heap, (e, y))
        return False

    for e in np.flatnonzero(fixed):
        join(e)
    contacts = []
    rank = np.zeros(len(between)) if first is None else (~first).astype(float)    # attachments first
    for e in between[np.lexsort((between, np.minimum(middle[i[between]], middle[j[between]]), rank))]:
        a, b = int(i[e]), int(j[e])
        if find(a) != find(b) or within(a, b):
            join(e)
        else:
            contacts.append(int(e))
    return np.array(contacts, dtype=np.int64)


def _surface_pieces(surface):
    """(mesh, piece): the surface's edge graph (CSR, each edge once, weighted by its length) and the connected
    piece of the mesh each vertex lies on."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    vertices = surface.vertices
    edges = surface.edges()     # each edge once
    weights = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    mesh = coo_matrix((weights, (edges[:, 0], edges[:, 1])), shape=(len(vertices),) * 2).tocsr()
    _, piece = connected_components(mesh, directed=False)
    return mesh, piece
