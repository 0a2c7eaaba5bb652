"""The sphere graph's contacts (``autorig.discretize.contacts``): between separate pieces of the mesh
(``_piece_contacts``) an edge that joins a piece where nothing joins it yet is kept, so is one whose spheres
are joined nearby anyway, and one that closes a loop through the body is cut; a piece's attachment at its open
rim goes first (``_rim_first``); the landmarks' bound on the distance over the surface (``_pressed_contacts``);
and the graph's bridges between pieces the packing left apart."""
from __future__ import annotations

import numpy as np

from autorig.discretize.contacts import LOOP, _piece_contacts

CHAINS = [(1, 2), (2, 3), (3, 4), (4, 5), (6, 7), (7, 8), (8, 9), (9, 10), (0, 11)]
BETWEEN = [(0, 1), (0, 6), (1, 11), (5, 10)]     # shoulders, a seam beside the left one, the hands


def arms_that_meet():
    """Centres and radii of a body with two arms on pieces of their own whose hands meet in front of it:
    sphere 0 the widest (the chest), 1-5 the left arm from the shoulder to the hand, 6-10 the right arm,
    11 a body sphere beside the left shoulder."""
    left = [(0.1 + 0.02 * k, 0.8 - 0.06 * k, 0.04 * k) for k in range(5)]
    c = np.array([(0.0, 0.75, 0.0), *left, *[(-x, y, z) for x, y, z in left], (0.1, 0.75, -0.02)])
    c[5], c[10] = (0.01, 0.6, 0.2), (-0.01, 0.6, 0.2)      # the hands, in front of the chest, 0.02 apart
    r = np.full(len(c), 0.02)
    r[0] = 0.1
    return c, r


def contacts_of(edges, between):
    c, r = arms_that_meet()
    pairs = np.array(edges)
    index = np.array([edges.index(e) for e in between])
    return {edges[e] for e in _piece_contacts(c, r, pairs, index, np.zeros(len(pairs), dtype=bool))}


def test_hands_of_two_arm_pieces_that_meet_are_cut_apart_and_the_shoulders_and_seam_kept():
    assert contacts_of(CHAINS + BETWEEN, BETWEEN) == {(5, 10)}
    c, _ = arms_that_meet()
    length = {e: float(np.linalg.norm(c[e[0]] - c[e[1]])) for e in CHAINS + BETWEEN}
    seam = length[(0, 1)] + length[(0, 11)] + length[(1, 11)]                  # the loop the seam closes
    hands = sum(length[e] for e in CHAINS[:8]) + length[(0, 1)] + length[(0, 6)]   # the one the hands close
    assert seam < LOOP < hands


def test_a_piece_joined_only_where_its_hand_meets_the_other_keeps_that_edge():
    """Without its shoulder's edge the right arm touches the rest only at the hands: there it is attached."""
    between = [e for e in BETWEEN if e != (0, 6)]
    assert contacts_of(CHAINS + between, between) == set()


def test_the_order_of_the_edges_does_not_change_what_is_cut():
    edges = CHAINS + BETWEEN
    assert contacts_of(edges[::-1], BETWEEN[::-1]) == {(5, 10)}


def _rod_field(pieces: int = 1, apart: float = 0.3):
    """The distance field of an upright square rod one height tall and a fifth of it wide (``pieces`` side by
    side, ``apart`` between their axes: separate pieces of the mesh, which overlap when nearer than 0.2), in
    the canonical frame."""
    import trimesh

    from autorig.discretize.distance import distance_field
    from autorig.embed.orient import working_axes
    from autorig.input.mesh import prepare
    rods = []
    for _ in range(pieces):
        rod = trimesh.creation.box(extents=(0.2, 1.0, 0.2))
        for _ in range(5):          # vertices a few hundredths apart, as a character's mesh has them
            rod = rod.subdivide()
        rods.append(rod)
    for k, rod in enumerate(rods):
        rod.apply_translation((apart * k, 0.0, 0.0))
    mesh = trimesh.util.concatenate(rods)
    prepared = prepare(np.asarray(mesh.vertices), np.asarray(mesh.faces), *working_axes("y", "z"), name="rod",
                       checked=True, unit="y")
    field = distance_field(*prepared.coarse())
    low, high = field.surface_vertices.min(axis=0), field.surface_vertices.max(axis=0)
    return field, low, high


def _limb_apart(low, high, x=None):
    """Spheres up the rod: a body (the four lowest), a button just above it, a limb (four spheres) a gap
    above the button (less than the button's radius, more than the others'), and a fingertip just above the
    limb: each of the four groups is its own piece, the button and the body each other's nearest, the limb
    and the fingertip each other's."""
    x = (low[0] + high[0]) / 2 if x is None else x
    z = (low[2] + high[2]) / 2
    y0 = low[1]
    ys = [0.10, 0.18, 0.26, 0.34,  0.405,  0.48, 0.56, 0.64, 0.72,  0.785]
    rs = [0.04, 0.04, 0.04, 0.04,  0.02,   0.04, 0.04, 0.04, 0.04,  0.02]
    c = np.array([(x, y0 + y, z) for y in ys])
    r = np.array(rs)
    pairs = np.array([(0, 1), (1, 2), (2, 3), (5, 6), (6, 7), (7, 8)])
    return c, r, pairs


def test_a_limb_left_apart_with_its_fingertip_is_bridged_to_the_body():
    """The first bridges join each piece to its nearest only: the body and a button join, the limb and its
    fingertip join, and the limb stood apart from the body (a MakeHuman hand cut off at a thin wrist). A piece
    of a limb's size is bridged to the body; the limb and body are one piece of the graph."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from autorig.discretize.graph import _bridge_pieces
    field, low, high = _rod_field()
    c, r, pairs = _limb_apart(low, high)
    edges = _bridge_pieces(field, c, r, pairs)
    count, labels = connected_components(coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])),
                                                    shape=(len(r),) * 2), directed=False)
    assert count == 1, labels
    assert {tuple(e) for e in edges.tolist()} >= {(3, 4), (8, 9)}      # the first bridges, as before


def test_a_limb_on_a_piece_of_its_own_is_not_bridged_to_the_body():
    """The same spheres with the limb and its fingertip in a second rod, a separate piece of the mesh (a shield
    on a forearm, a forearm held by the other hand): apart from the first (the segment to the body leaves the
    mesh) or pushed into it (the segment stays inside), the limb is not bridged to the body, whose surface is
    another piece."""
    from autorig.discretize.graph import _bridge_pieces
    for apart in (0.3, 0.17):
        field, low, high = _rod_field(pieces=2, apart=apart)
        # each piece's spheres nearer its own rod's outer face than the other rod's face inside it
        c, r, pairs = _limb_apart(low, high, x=low[0] + 0.05)
        c[5:, 0] = low[0] + 0.15 + apart
        edges = {tuple(e) for e in _bridge_pieces(field, c, r, pairs).tolist()}
        assert not any((a <= 4) != (b <= 4) for a, b in edges), (apart, edges)


def _u_sheet(step: float = 0.02):
    """A flat sheet in the shape of a U, one unit tall and 0.5 wide, its two arms 0.1 wide and 0.3 apart at the
    top: (vertices [V, 3], faces [F, 3]) on a grid of ``step``."""
    n, m = int(round(0.5 / step)), int(round(1.0 / step))
    notch = [(x, y) for x in range(n) for y in range(m) if 0.1 <= (x + 0.5) * step <= 0.4 and (y + 0.5) * step > 0.2]
    cells = [(x, y) for x in range(n) for y in range(m) if (x, y) not in set(notch)]
    index, vertices, faces = {}, [], []

    def corner(x, y):
        if (x, y) not in index:
            index[(x, y)] = len(vertices)
            vertices.append((x * step, y * step, 0.0))
        return index[(x, y)]

    for x, y in cells:
        a, b, c, d = corner(x, y), corner(x + 1, y), corner(x + 1, y + 1), corner(x, y + 1)
        faces += [(a, b, c), (a, c, d)]
    return np.array(vertices), np.array(faces)


def test_landmarks_bound_the_distance_over_the_surface_and_tell_the_arms_of_a_u_apart():
    """``_pressed_contacts``' bound: |d(L, a) - d(L, b)| over its landmarks L never exceeds the distance between a
    and b over the surface, and for the tops of a U's two arms, 0.3 apart in space, it is the way round the U's
    bottom (1.6 over the sheet) within a few steps, since the landmarks lie at the arms' ends."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from autorig.discretize.contacts import _landmark_distances
    from autorig.input.facing import mesh_edges

    vertices, faces = _u_sheet()
    edges = mesh_edges(len(vertices), faces)
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    both = coo_matrix((np.r_[length, length], (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]])),
                      shape=(len(vertices),) * 2).tocsr()
    reach = _landmark_distances(both, vertices, np.arange(len(vertices)))
    exact = dijkstra(both, directed=True, indices=np.arange(0, len(vertices), 7))
    rows = np.arange(0, len(vertices), 7)
    bound = np.abs(reach[:, rows, None] - reach[:, None, :]).max(axis=0)
    assert np.all(bound <= exact + 1e-9)
    left = int(np.argmin(np.linalg.norm(vertices - (0.05, 1.0, 0.0), axis=1)))
    right = int(np.argmin(np.linalg.norm(vertices - (0.45, 1.0, 0.0), axis=1)))
    apart = float(np.abs(reach[:, left] - reach[:, right]).max())
    round_the_bottom = float(dijkstra(both, directed=True, indices=left)[right])
    assert round_the_bottom > 1.5 and apart > 0.9 * round_the_bottom


def test_a_piece_s_attachment_at_its_open_rim_is_kept_before_a_hand_pressed_nearer_the_middle():
    """The left arm, a piece of its own, joined to the body at its shoulder (13, 1) and where its hand presses
    into the body by the hip (5, 12), nearer the body's middle: taken by that distance alone, the hand's edge
    holds the arm and the shoulder's closes the loop and is cut; with the shoulder's edge marked an attachment
    (its sphere by the arm piece's open rim, ``_rim_first``) the hand's is cut."""
    c, r = arms_that_meet()
    c = np.vstack([c, (0.04, 0.72, 0.0), (0.06, 0.78, 0.0)])    # 12: the body by the left hip, 13: by the shoulder
    r = np.append(r, (0.02, 0.02))
    c[5] = (0.07, 0.68, 0.02)                                   # the left hand, pressed in beside 12
    edges = CHAINS[:4] + [(0, 12), (0, 13), (1, 13), (5, 12)]
    pairs, between, none = np.array(edges), np.array([6, 7]), np.zeros(len(edges), dtype=bool)
    assert {edges[e] for e in _piece_contacts(c, r, pairs, between, none)} == {(1, 13)}
    assert {edges[e] for e in _piece_contacts(c, r, pairs, between, none, np.array([True, False]))} == {(5, 12)}


def test_a_sphere_by_a_limb_piece_s_open_rim_holds_its_attachment():
    """``_rim_first``: a tube open at its top (an arm piece, hidden at the shoulder inside the body) and a closed
    box (the body) around that end; the edge from the body to the tube's sphere by the open rim is an attachment,
    the one to the sphere at its closed far end (the hand) is not."""
    from types import SimpleNamespace

    import trimesh

    from autorig.discretize.contacts import _rim_first

    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    tube = trimesh.creation.cylinder(radius=0.05, height=0.6, sections=12)
    tube.apply_translation((0.0, 0.0, -0.2))         # from z = -0.5 (its far end) to 0.1, inside the box
    top = tube.triangles_center[:, 2] > 0.1 - 1e-9
    tube = trimesh.Trimesh(tube.vertices, tube.faces[~top], process=False)      # open at the top
    vertices = np.vstack([box.vertices, tube.vertices])
    faces = np.vstack([box.faces, tube.faces + len(box.vertices)])
    piece = np.r_[np.zeros(len(box.vertices), dtype=np.int64), np.ones(len(tube.vertices), dtype=np.int64)]
    c = np.array([(0.3, 0.3, 0.3), (0.0, 0.0, 0.05), (0.0, 0.0, -0.45)])
    r = np.array([0.2, 0.05, 0.05])
    nearest = lambda point, members: int(members[np.argmin(np.linalg.norm(vertices[members] - point, axis=1))])
    vertex = np.array([nearest(c[0], np.flatnonzero(piece == 0))] + [nearest(p, np.flatnonzero(piece == 1))
                                                                      for p in c[1:]])
    surface = SimpleNamespace(vertices=vertices, faces=faces)
    assert _rim_first(surface, piece, vertex, c, r, np.array([(0, 1), (0, 2)])).tolist() == [True, False]


def test_a_sphere_between_two_faces_reads_both_whichever_its_nearest_point_is():
    """A medial sphere touches the surface on two sides at once, and which of the two its nearest point is, is a
    rounding error's choice (a sphere inside both a hand and the hip it presses into). ``_far_side_corners`` reads
    the other side: in a flat slab, a sphere half-way between its faces moved up or down by 1e-9 has the top face
    or the bottom one nearest, and with its far side it reads both either way."""
    import trimesh

    from autorig.discretize.contacts import _far_side_corners, _nearest_corners
    from autorig.discretize.surface import SurfaceQuery

    slab = trimesh.creation.box(extents=(1.0, 0.1, 1.0))
    slab = slab.subdivide().subdivide()
    surface = SurfaceQuery(slab.vertices, slab.faces)
    r = np.array([0.05, 0.05])
    sides = []
    for nudge in (1e-9, -1e-9):
        c = np.array([[0.1, nudge, 0.1], [-0.2, nudge, 0.15]])
        vertex, _ = _nearest_corners(surface, c, np.arange(2))
        other, gap = _far_side_corners(surface, c, r, vertex, np.arange(2))
        heights = np.sign(surface.vertices[np.c_[vertex, other], 1])
        sides.append(heights)
        assert np.all(gap < 0.3)
    assert sides[0][0, 0] == -sides[1][0, 0]                        # the nearest side: up, then down
    for heights in sides:
        assert np.all(np.sort(heights, axis=1) == [-1, 1])          # both faces, either way
