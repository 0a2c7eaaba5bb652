"""Tips read off the surface (``autorig.readoff.tips``): at the ends of the right limbs, and still when the mesh moves
by a millionth of its height (issue 37: a head's end jumped 7-24 % of the height, a fox's tail end 29 %)."""
import numpy as np
import pytest

import autorig
from autorig.pipeline import RigOptions
from autorig.samples import mannequin
from autorig.readoff.tips import Surface, core_of

TIPS = ("head_end", "left_hand_end", "right_hand_end", "left_toe_end", "right_toe_end")


@pytest.fixture(scope="module")
def sample():
    return mannequin(pose="t", resolution=56)


def canonical(sample):
    """Vertices and joints one unit tall, the mid-plane at x = 0 (the frame tips are read in)."""
    lo, hi = sample.vertices.min(axis=0), sample.vertices.max(axis=0)
    scale = hi[1] - lo[1]
    lo = np.array([(lo[0] + hi[0]) / 2, lo[1], lo[2]])
    return (sample.vertices - lo) / scale, {n: (p - lo) / scale for n, p in sample.joints.items()}


def test_each_tip_is_its_own_limbs_end(sample):
    vertices, joints = canonical(sample)
    surface = Surface(vertices, sample.faces, core_of(vertices, sample.faces))
    for name in TIPS:
        parent = {"head_end": "head", "left_hand_end": "left_wrist", "right_hand_end": "right_wrist",
                  "left_toe_end": "left_toe", "right_toe_end": "right_toe"}[name]
        # Started anywhere in the limb's last bone, the climb reaches the same end.
        for t in (0.3, 0.7):
            start = joints[parent] + t * (joints[name] - joints[parent])
            tip = surface.tip(start, midline=name == "head_end")
            others = [n for n in TIPS if n != name]
            assert np.linalg.norm(tip - joints[name]) < min(np.linalg.norm(tip - joints[n]) for n in others)
            assert np.linalg.norm(tip - joints[name]) < 0.05, name


def test_the_core_is_the_volume_centroid():
    # A closed box from 0 to (1, 2, 3), faces outward: its centroid is its centre, whatever its vertex order.
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 2) for z in (0, 3)], float)
    import trimesh
    box = trimesh.convex.convex_hull(v)
    assert np.allclose(core_of(np.asarray(box.vertices), np.asarray(box.faces)), [0.5, 1.0, 1.5])


def test_tips_do_not_jump_when_the_mesh_moves_by_a_millionth(sample):
    vertices, faces = sample.vertices, sample.faces
    height = np.ptp(vertices[:, 1])
    base = autorig.rig((vertices, faces), "biped", RigOptions(up="y", front="z"))
    for seed in range(2):
        noisy = vertices + np.random.default_rng(seed).uniform(-1e-6, 1e-6, vertices.shape) * height
        other = autorig.rig((noisy, faces), "biped", RigOptions(up="y", front="z"))
        for name in TIPS:
            i = base.names.index(name)
            assert np.linalg.norm(other.joints[i] - base.joints[i]) / height < 0.005, name


def test_a_separate_small_piece_does_not_take_a_tip(sample):
    """A nail or an eye (a separate piece) near a limb's end does not become the limb's tip."""
    vertices, joints = canonical(sample)
    nail = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]) + joints["left_hand_end"] + [0.004, 0, 0]
    faces = np.vstack([sample.faces, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + len(vertices)])
    all_vertices = np.vstack([vertices, nail])
    surface = Surface(all_vertices, faces, core_of(all_vertices, faces))
    tip = surface.tip(joints["left_hand_end"] + [0.004, 0.0, 0.0])
    assert np.linalg.norm(tip - joints["left_hand_end"]) < 0.05


def _tops_by_lexsort(graph, reach):
    """tips._tops as first written (every edge sorted by vertex, reach and number): the reference."""
    coo = graph.tocoo()
    a, b = coo.row, coo.col
    order = np.lexsort((b, reach[b], a))
    a, b = a[order], b[order]
    last = np.flatnonzero(np.r_[a[1:] != a[:-1], True])
    up = np.arange(len(reach))
    climbs = reach[b[last]] > reach[a[last]]
    up[a[last][climbs]] = b[last][climbs]
    for _ in range(64):
        nxt = up[up]
        if np.array_equal(nxt, up):
            break
        up = nxt
    return up


def test_each_vertex_climbs_to_the_top_the_edge_by_edge_sort_finds(sample):
    """tips._tops takes each vertex's highest neighbour by reductions over the graph's rows; ties (the highest
    numbered wins), unreached vertices (-inf) and a vertex with no edge climb as the sorted edges had them."""
    from scipy.sparse import csr_matrix

    from autorig.readoff.tips import _tops
    vertices, faces = canonical(sample)[0], sample.faces
    surface = Surface(vertices, faces, core_of(vertices, faces))
    graph = surface.graph
    lonely = csr_matrix((graph.data, graph.indices, np.r_[graph.indptr, graph.indptr[-1]]),
                        shape=(graph.shape[0] + 1, graph.shape[1] + 1))     # one more vertex, with no edge
    for reach in (surface.reach, np.round(surface.reach, 2),
                  np.where(np.arange(len(surface.reach)) % 7 == 0, -np.inf, np.round(surface.reach, 1))):
        assert np.array_equal(_tops(graph, reach), _tops_by_lexsort(graph, reach))
        assert np.array_equal(_tops(lonely, np.r_[reach, 5.0]), _tops_by_lexsort(lonely, np.r_[reach, 5.0]))
    assert len(np.unique(_tops(graph, surface.reach))) > 3       # the limbs' ends, each its own top


def _rod(centre, axis, length, radius=0.008, step=0.01, sides=6, width=None):
    """(vertices, faces) of a closed six-sided rod with a ring of vertices every ``step`` along it: a spear.
    width: a function of the place along the rod (-length / 2 .. length / 2) giving the ring's half-width
    across (a blade, flat as ``radius``, with a crossguard)."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    u = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    rings = int(round(length / step)) + 1
    angles = 2 * np.pi * np.arange(sides) / sides
    along = np.linspace(-length / 2, length / 2, rings)
    half = np.full(rings, radius) if width is None else np.array([width(t) for t in along])
    circle = (half[:, None, None] * np.cos(angles)[None, :, None] * u
              + radius * np.sin(angles)[None, :, None] * w)
    vertices = (np.asarray(centre, float) + along[:, None, None] * axis + circle).reshape(-1, 3)
    faces = []
    for r in range(rings - 1):
        for s in range(sides):
            a, b = r * sides + s, r * sides + (s + 1) % sides
            faces += [[a, b, a + sides], [b, b + sides, a + sides]]
    ends = len(vertices) + np.arange(2)
    vertices = np.vstack([vertices, np.asarray(centre) + np.outer([-length / 2, length / 2], axis)])
    for s in range(sides):
        last = (rings - 1) * sides
        faces += [[ends[0], (s + 1) % sides, s], [ends[1], last + s, last + (s + 1) % sides]]
    return vertices, np.array(faces)


@pytest.mark.parametrize("behind", [0.05, 0.3])
def test_a_hand_holding_a_spear_ends_at_the_hand_not_at_the_spear_point(sample, behind):
    """A spear (a separate rod) through the fist, its grip ``behind`` from its back end: the arm's path ends in
    the shaft, and the hand's tip climbed from there ran up the shaft to the spear's point (re-posed 0 A.D.
    spearmen: half the height past the hand, wrists 15-18 % off). A held stick is not the hand's end."""
    vertices, joints = canonical(sample)
    grip = joints["left_wrist"] + 0.6 * (joints["left_hand_end"] - joints["left_wrist"])
    length = 0.6
    rod_v, rod_f = _rod(grip + [0.0, 0.0, length / 2 - behind], [0.0, 0.0, 1.0], length)
    all_vertices = np.vstack([vertices, rod_v])
    faces = np.vstack([sample.faces, rod_f + len(vertices)])
    surface = Surface(all_vertices, faces, core_of(all_vertices, faces))
    tip = surface.tip(grip)
    assert np.linalg.norm(tip - joints["left_hand_end"]) < 0.05
    # the head's and the other hand's tips are read as before
    assert np.linalg.norm(surface.tip(joints["head"], midline=True) - joints["head_end"]) < 0.05


def test_a_limb_that_is_a_rod_of_its_own_keeps_its_end(sample):
    """A stick with no other piece near the path's end is a limb of its own (a rod-like separate leg): its end
    is climbed on it."""
    vertices, joints = canonical(sample)
    rod_v, rod_f = _rod(joints["left_hand_end"] + [0.3, 0.0, 0.0], [1.0, 0.0, 0.0], 0.4)
    all_vertices = np.vstack([vertices, rod_v])
    faces = np.vstack([sample.faces, rod_f + len(vertices)])
    surface = Surface(all_vertices, faces, core_of(all_vertices, faces))
    start = joints["left_hand_end"] + [0.4, 0.0, 0.0]
    tip = surface.tip(start)
    assert tip[0] > start[0] + 0.05       # climbed outward along the rod, away from the body


def test_a_hand_holding_a_sword_with_a_crossguard_ends_at_the_hand(sample):
    """A sword: a flat blade 0.03 wide with a crossguard 0.14 across, one piece. The guard makes it as wide as
    a forearm across (a fifth of its length), but its surface is a blade's: it is held, not the hand's end."""
    vertices, joints = canonical(sample)
    grip = joints["left_wrist"] + 0.6 * (joints["left_hand_end"] - joints["left_wrist"])
    length = 0.5
    blade = lambda t: 0.07 if -0.17 <= t <= -0.15 else (0.01 if t < -0.17 else 0.015)   # noqa: E731
    sword_v, sword_f = _rod(grip + [0.0, length / 2 - 0.05, 0.0], [0.0, 1.0, 0.0], length, radius=0.004,
                            width=blade)
    all_vertices = np.vstack([vertices, sword_v])
    faces = np.vstack([sample.faces, sword_f + len(vertices)])
    surface = Surface(all_vertices, faces, core_of(all_vertices, faces))
    assert np.linalg.norm(surface.tip(grip) - joints["left_hand_end"]) < 0.05


def test_a_tip_read_behind_its_limbs_start_is_not_its_end():
    """A limb's path runs from its parent's joint to its end; the tip read off the surface may fall short of the
    path's end (a path that ran past the end cap) or beyond it, never behind the limb's start: such a read
    climbed another part (a hand resting on the hip, its arm a separate piece, read up to the shoulder)."""
    from autorig.embed.refine import _beyond_start
    path = np.array([[0.0, 0.5, 0.0], [0.1, 0.55, 0.0], [0.2, 0.6, 0.0]])
    assert _beyond_start(path, np.array([0.25, 0.62, 0.0]))       # past the end: the limb's end cap
    assert _beyond_start(path, np.array([0.15, 0.58, 0.01]))      # short of the path's end
    assert not _beyond_start(path, np.array([-0.05, 0.45, 0.0]))  # behind where the limb starts
    assert not _beyond_start(path[:1], np.array([0.1, 0.5, 0.0]))  # no chord: the path's own end


def _sheet(n: int):
    """A flat square sheet of n x n vertices (x in [-0.5, 0.5], y in [0, 1], z = 0) and its ``Surface``, whose
    reach a test sets: (x, y grids [n, n], vertices [n * n, 3], index [n, n] of the vertices, surface)."""
    x, y = np.meshgrid(np.linspace(-0.5, 0.5, n), np.linspace(0.0, 1.0, n), indexing="ij")
    vertices = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    index = np.arange(n * n).reshape(n, n)
    a, b, c, d = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    faces = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return x, y, vertices, index, Surface(vertices, faces, np.array([0.0, 0.5, -1.0]))


def test_a_climb_to_the_lower_of_two_tops_within_a_cap_reads_the_head_tip_around_the_higher():
    """A round head's crown and the back of it are two tops of the reach within a cap of each other; which of the
    two a climb reached flipped when the mesh moved a millionth (re-posed CesiumMan's head 0.6 % of the height).
    A mid-plane part's cap is read around the higher top, whichever the climb reached first."""
    from autorig.readoff.tips import CAP, _tops

    n = 41
    x, y, vertices, index, surface = _sheet(n)

    def bump(cy, h, fall):      # a top at (0, cy) of height h, falling by ``fall`` at 0.15 from it
        return h - fall * (x ** 2 + (y - cy) ** 2) / 0.15 ** 2

    def tips(lower, fall):
        reach = np.maximum(bump(0.35, 1.0, fall), bump(0.65, 1.0 - lower, fall)).ravel()
        surface.reach, surface.top = reach, _tops(surface.graph, reach)
        near_low, near_high = index[n // 2, int(0.7 * (n - 1))], index[n // 2, int(0.3 * (n - 1))]
        assert surface.top[near_low] != surface.top[near_high]         # the climbs reach different tops
        return surface.tip(vertices[near_low], midline=True), surface.tip(vertices[near_high], midline=True)

    low, high = tips(0.6 * CAP, 0.2 * CAP)      # joined by a ridge within the cap
    assert np.allclose(low, high)
    # a top more than a cap lower, beyond a valley deeper than the cap (a part of its own), keeps its own tip
    low, high = tips(1.5 * CAP, 4 * CAP)
    assert np.linalg.norm(low - high) > 0.2


def test_a_hands_climb_to_either_of_two_fingertips_reads_the_same_end_but_not_one_a_hand_away():
    """A hand's fingertips are tops of the reach within a cap of each other, a finger's width apart; which one
    the climb from the arm's path's end reached flipped when the mesh moved a millionth (a MakeHuman body's left
    hand, its end 0.6 % of the height apart). A paired limb's cap is read around the higher top when the two lie
    within ``FINGERS``; a higher top farther away is not the hand's, and one farther than a hand's length (the
    leg a hand rests on) leaves no tip to read."""
    from autorig.readoff.tips import CAP, FINGERS, _tops

    n = 161
    x, y, vertices, index, surface = _sheet(n)

    def tips(apart):
        def bump(cy, h):      # a top at (0, cy) of height h, falling by 0.2 of a cap at a quarter of ``apart``
            return h - 0.2 * CAP * (x ** 2 + (y - cy) ** 2) / (apart / 4) ** 2
        low_y, high_y = 0.5 + apart / 2, 0.5 - apart / 2
        reach = np.maximum(bump(high_y, 1.0), bump(low_y, 1.0 - 0.5 * CAP)).ravel()
        surface.reach, surface.top = reach, _tops(surface.graph, reach)
        step = 1.0 / (n - 1)
        near_low = index[n // 2, int(round((low_y + apart / 4) / step))]
        near_high = index[n // 2, int(round((high_y - apart / 4) / step))]
        assert surface.top[near_low] != surface.top[near_high]         # the climbs reach different tops
        return surface.tip(vertices[near_low]), surface.tip(vertices[near_high])

    low, high = tips(0.6 * FINGERS)             # two fingertips
    assert np.allclose(low, high)
    low, high = tips(1.5 * FINGERS)             # a higher top beyond the fingers: each cap read around its own
    assert low[1] > high[1] + 0.01
    low, high = tips(3 * FINGERS)               # a hand's length away (``HAND``): the lower cap is no hand's end
    assert low is None and abs(high[1] - (0.5 - 1.5 * FINGERS)) < 0.02


def test_a_hands_climb_that_stops_on_a_bump_below_a_leg_reads_no_tip():
    """A hand pressed into the hip: the surface nearest the arm's path's end is the hip's, and its climb stops on
    a bump there, below the leg whose reach rises far above it; the cap around the bump was the whole leg, and
    its centroid put a MakeHuman body's hand end at its crotch (both wrists 17 % of the height off, hands on the
    hips). No tip is read: the arm's chain ends at its path's end."""
    from autorig.readoff.tips import CAP, _tops

    n = 161
    x, y, vertices, index, surface = _sheet(n)
    bump = 0.3 + 0.5 * CAP - 0.5 * CAP * (x ** 2 + (y - 0.7) ** 2) / 0.02 ** 2
    at_bump = index[n // 2, int(round(0.7 * (n - 1)))]
    reach = np.maximum(1.0 - y, bump).ravel()                        # the leg rises to 1 at y = 0
    surface.reach, surface.top = reach, _tops(surface.graph, reach)
    assert surface.top[at_bump] == at_bump                           # the bump is a top of its own
    assert surface.tip(vertices[at_bump]) is None
    assert surface.tip(vertices[at_bump], midline=True) is not None  # a head's cap reaches its highest top


def test_a_hands_tip_read_at_another_limbs_end_is_not_taken():
    """A hand pressed into the hip, climbed from the hip, read the toes' cap (MakeHuman bodies re-posed with their
    hands on their hips: wrists 17-22 % of the height off). A paired limb's tip nearer another paired limb's end
    sphere than its own path's end is that limb's; the other hand's end is not counted (hands held together),
    nor the head's, nor is a tip by its own path's end."""
    from autorig.embed.refine import _at_other_end
    from autorig.template import load_template
    template = load_template("biped")
    names = {n: i for i, n in enumerate(template.names)}
    mirror = template.mirror_of()
    hand, other_hand = names["left_hand_end"], names["right_hand_end"]
    ends = {hand: np.array([0.11, 0.55, 0.0]), other_hand: np.array([-0.11, 0.55, 0.0]),
            names["left_toe_end"]: np.array([0.1, 0.01, 0.05]), names["right_toe_end"]: np.array([-0.1, 0.01, 0.05]),
            names["head_end"]: np.array([0.0, 0.95, 0.05])}
    path_end = ends[hand]
    assert _at_other_end(np.array([0.11, 0.01, 0.07]), path_end, hand, ends, mirror)        # the toes' cap
    assert not _at_other_end(np.array([0.0, 0.99, 0.02]), path_end, hand, ends, mirror)     # the crown's: a
    # mid-plane end is not counted (``_beyond_start`` takes no tip up behind the arm's start)
    assert not _at_other_end(np.array([0.13, 0.50, 0.02]), path_end, hand, ends, mirror)    # its own fingers
    assert not _at_other_end(np.array([-0.09, 0.55, 0.0]), path_end, hand, ends, mirror)    # the other hand's


def test_a_head_tip_read_from_the_mid_plane_between_two_horns_is_the_pairs_middle():
    """A head with two horns (a mirrored pair of tops) whose path ends on the mid-plane: the surface nearest the
    path's end, and the climb from it, take either horn as the floats fall, and so did the climb from its mirror
    image (the same point), so both reached one horn and the head's tip was that horn's, not the pair's middle
    (0 A.D.'s aurochs walking with its head low: 20 % of the height apart under 1e-6 noise). The second climb
    starts at the mirror image of the first's end: the pair's middle, from either side of the plane."""
    from autorig.readoff.tips import _tops

    n = 41
    x, y, vertices, index, surface = _sheet(n)
    horn = lambda cx: 1.0 - ((x - cx) ** 2 + (y - 0.8) ** 2)     # noqa: E731
    reach = np.maximum(horn(-0.25), horn(0.25)).ravel()
    surface.reach, surface.top = reach, _tops(surface.graph, reach)
    for side in (-1e-7, 0.0, 1e-7):
        tip = surface.tip(np.array([side, 0.5, 0.0]), midline=True)
        assert abs(tip[0]) < 1e-9 and tip[1] > 0.7, (side, tip)
