"""Which bones of a user's skeleton heat the surface (``autorig MESH --skeleton FILE``).

An artist's skeleton is not a template: it has joints that carry no bone, bones that lie outside the body and
joints stacked on one another. Bone heat (``autorig.weights.attach``) treats every bone as a heat source, so before it
runs each bone is judged by the mesh's geometry alone (never by names or flags in the file):

- a bone of (almost) no length heats nothing: it has no direction, and at a tie it would only take a share of
  the heat of the real bones meeting there (glTF rigs often stack a joint on its parent);
- a bone whose parent is not in the part of the mesh that holds its child is split: the parent's share stops
  where the bone leaves the mesh, and the piece inside the child's part heats for the child. The Fox's root bone
  rises from the origin, on the ground between the legs, into the hips: the piece from the belly up to the hips
  is body around the hip joint (Fox top-1 90.0 -> 91.4 % against the whole bone left out); a prop held in the
  hand, with a joint of its own, goes to that joint rather than to the wrist;
- a bone lying mostly outside the mesh heats nothing: "inside" is the generalized winding number >= 1/2, or
  lying on the surface within ``NEAR_SURFACE``, so bones in a flat or open mesh still count;
- a leaf joint gets a tip bone of its own when the mesh carries on beyond it (the Fox's front legs stop at the
  "hand" joints, which carry the paws; a hand joint carries the hand): the leaf's incoming bone is extended
  and, if the mesh goes on past the leaf further than the body is thick there, the leaf owns a bone from
  itself towards that exit (Fox top-1 84.5 -> 91.4 %, RiggedSimple per-joint 66.7 -> 100 %). A leaf at the
  body's end (a head-top or fingertip "_end" joint) stays a tip with no weight (huesitos' two "_end" leaves,
  which its artist left unweighted: per-joint top-1 91.9 -> 100 % once they are recognised as ends);
- a bone that runs along other bones heats nothing: a joint with several children owns a bone to each, and
  when one child sits at the far end of a chain that starts at another child (animation_with_skeleton's root has
  a bone along the whole length of one of its two chains), that bone only doubles the chain's own bones and
  would take a share of every vertex along it (per-joint top-1 18.4 -> 29.0 %). The longest such bone goes
  first, until none is left;
- if those rules leave no bone at all (a skeleton entirely outside the mesh, e.g. in other units), every bone
  of non-zero length heats, so that every vertex is still weighted.

The percentages are benchmarks/skeleton_weights.py's dominant-joint agreement with the artists' weights. All
lengths here are in the canonical frame of ``autorig.input.mesh.prepare`` (the mesh one unit long along its
longest side), so the rules do not depend on the mesh's units.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..input.budget import checkpoint

ALONG = 0.02            # a bone whose points lie this close (x its length) to other bones runs along them
ZERO_LENGTH = 1e-6      # bones shorter than this (x the mesh's longest side) have no direction
BONE_SAMPLES = 16       # points per bone for the inside test
INSIDE_FRACTION = 0.5   # a bone heats if at least this fraction of its points is inside (or on) the mesh
NEAR_SURFACE = 0.01     # a point this close to the surface (x longest side) counts as inside: thin/open meshes
TIP_REACH = 0.2         # a leaf gets a tip bone if the mesh goes on past it along its bone further than this
                        # fraction of the bone (and further than the leaf's depth below the surface)
TIP_LENGTH = 0.5        # the tip bone's length, as a fraction of the incoming bone, at most to the mesh's exit
TIP_SEARCH = 2.0        # how far past a leaf to look for the exit, as a multiple of the incoming bone


@dataclass
class HeatPlan:
    """The bones that heat the surface, in the form ``autorig.weights.attach.bone_heat`` takes them.

    joints   [J + T, 3] the skeleton's J joints, then one virtual tip joint per leaf given a tip bone
    parents  [J + T] heating structure: for a skeleton joint c, its parent if the bone parent -> c heats, else -1
             (the bone is left out by making c a root); for a tip joint, the leaf it extends
    owners   [J + T] the weight column that receives each bone's heat: the bone's parent joint (a glTF joint
             owns the bones that leave it), the leaf itself for its tip bone
    tips         names of leaves given a tip bone (they carry weight)
    outside      names of joints whose incoming bone lies outside the mesh (heats nothing)
    doubled      names of joints whose incoming bone runs along other bones (heats nothing)
    zero_length  names of joints stacked on their parent (their incoming bone heats nothing)
    fallback     True when no bone passed the rules and all bones of non-zero length heat
    """
    joints: np.ndarray
    parents: np.ndarray
    owners: np.ndarray
    tips: list[str] = field(default_factory=list)
    outside: list[str] = field(default_factory=list)
    zero_length: list[str] = field(default_factory=list)
    doubled: list[str] = field(default_factory=list)
    fallback: bool = False


def plan_heat(vertices, faces, names, joints, parents, tips=None) -> HeatPlan:
    """Decide which bones heat (see the module docstring).

    vertices [W, 3], faces [G, 3]: a clean, outward-facing mesh (``PreparedMesh.work_vertices/work_faces``), one
        unit along its longest side; joints [J, 3] in the same frame; names [J]; parents [J] (parents first,
        -1 for a root); tips [J, 3] or None: where the skeleton file says a joint's own bone ends (a BVH End
        Site), NaN elsewhere; a leaf with one gets that bone if it passes the inside test.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    P = np.asarray(joints, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.int64)
    J = len(P)
    size = float(np.ptp(V, axis=0).max()) or 1.0
    given_tips = np.full((J, 3), np.nan) if tips is None else np.asarray(tips, dtype=np.float64)

    length = np.array([np.linalg.norm(P[c] - P[p]) if p >= 0 else 0.0 for c, p in enumerate(parents)])
    bones = np.flatnonzero(parents >= 0)
    zero = bones[length[bones] < ZERO_LENGTH * size]
    real = bones[length[bones] >= ZERO_LENGTH * size]

    # Each bone heats from its parent to its child; when the parent is not in the part of the mesh the child is in
    # (see split_at_parts), the parent's share stops where the bone leaves the mesh and the piece inside the
    # child's part goes to the child as a stub.
    ends = P.copy()                                       # ends[c]: where the bone into c stops heating for parent
    stubs: list[tuple[int, np.ndarray]] = []
    for c, (leaves_parent, entry) in split_at_parts(V, F, P, parents, real, size).items():
        ends[c] = leaves_parent
        if np.linalg.norm(entry - P[c]) >= ZERO_LENGTH * size:
            stubs.append((c, entry))
    split = np.array([c for c in real if not np.array_equal(ends[c], P[c])], dtype=np.int64)
    long_enough = np.linalg.norm(ends[real] - P[parents[real]], axis=1) >= ZERO_LENGTH * size
    inside = np.zeros(len(real))
    if long_enough.any():
        inside[long_enough] = inside_fraction(V, F, P[parents[real[long_enough]]], ends[real[long_enough]], size)
    heating = real[inside >= INSIDE_FRACTION]
    fallback = len(heating) == 0 and len(real) > 0 and not stubs
    if fallback:
        heating, ends = real, P.copy()
        split, stubs = np.zeros(0, dtype=np.int64), []
    outside = real[np.isin(real, heating, invert=True)]
    doubled = along_other_bones(P, parents, heating[np.isin(heating, split, invert=True)])
    heating = heating[np.isin(heating, doubled, invert=True)]

    has_child = np.zeros(J, bool)
    has_child[parents[parents >= 0]] = True
    tip_joints, tip_leaves = [], []
    for leaf in np.flatnonzero(~has_child & (parents >= 0)):
        checkpoint()
        tip = given_tips[leaf]
        if not np.isfinite(tip).all() or np.linalg.norm(tip - P[leaf]) < ZERO_LENGTH * size:
            tip = leaf_tip(V, F, P[parents[leaf]], P[leaf], size)
        if tip is None:
            continue
        if inside_fraction(V, F, P[leaf][None], tip[None], size)[0] >= INSIDE_FRACTION:
            tip_joints.append(tip)
            tip_leaves.append(int(leaf))

    # bone_heat takes bones as parent -> joint: a whole bone keeps its child joint; a split bone's heating part
    # ends at a virtual joint owned by the parent, and every tip and stub is a virtual joint owned by its joint.
    heat_parents = np.full(J, -1)
    whole = heating[np.isin(heating, split, invert=True)]
    heat_parents[whole] = parents[whole]
    cut = heating[np.isin(heating, split)]
    extra = [ends[c] for c in cut] + tip_joints + [e for _, e in stubs]
    extra_parent = [int(parents[c]) for c in cut] + tip_leaves + [c for c, _ in stubs]
    all_joints = np.vstack([P] + [np.asarray(t)[None] for t in extra])
    all_parents = np.concatenate([heat_parents, extra_parent]).astype(np.int64)
    owners = np.concatenate([parents, extra_parent]).astype(np.int64)
    return HeatPlan(joints=all_joints, parents=all_parents, owners=owners,
                    tips=[names[j] for j in tip_leaves],
                    outside=[names[c] for c in outside],
                    doubled=[names[c] for c in doubled],
                    zero_length=[names[c] for c in zero], fallback=fallback)


def inside_fraction(V, F, heads, tails, size: float) -> np.ndarray:
    """Fraction [B] of BONE_SAMPLES points along each segment heads[b] -> tails[b] ([B, 3] each) that lie inside
    the mesh (V [W, 3], F [G, 3]; winding number >= 1/2) or within NEAR_SURFACE * size of its surface."""
    import igl

    t = (np.arange(BONE_SAMPLES) + 0.5) / BONE_SAMPLES
    X = (heads[:, None, :] + t[None, :, None] * (tails - heads)[:, None, :]).reshape(-1, 3)
    winding = igl.fast_winding_number(V, F, X)
    squared, _, _ = igl.point_mesh_squared_distance(X, V, F)
    inside = (winding >= 0.5) | (np.sqrt(squared) <= NEAR_SURFACE * size)
    return inside.reshape(len(heads), BONE_SAMPLES).mean(axis=1)


def leaf_tip(V, F, head, leaf, size: float) -> np.ndarray | None:
    """The end [3] of a tip bone for the leaf joint ``leaf`` whose bone comes from ``head``, or None when the
    mesh does not go on past the leaf (it sits at the body's end, or outside it).

    Points along the extension of the bone past the leaf, up to TIP_SEARCH bone lengths, are tested with the
    winding number; the mesh "goes on" if the first point outside lies further from the leaf than TIP_REACH
    times the bone and than the leaf's depth (its distance to the surface). On the artists' rigs the leaves at
    the body's end have the exit within 0.03-0.06 bone lengths (head-top and fingertip "_end" joints) and the
    leaves that carry a part 0.34-2 (hands, heads, toes, a tail's last joint, RiggedSimple's upper joint).
    """
    import igl

    direction = leaf - head
    bone = float(np.linalg.norm(direction))
    if bone < ZERO_LENGTH * size:
        return None
    direction = direction / bone
    steps = np.linspace(0.0, TIP_SEARCH * bone, 65)
    X = leaf + steps[:, None] * direction
    inside = igl.fast_winding_number(V, F, X) >= 0.5
    if not inside[0]:
        return None
    exit_at = steps[np.argmin(inside)] if not inside.all() else steps[-1]
    depth = float(np.sqrt(igl.point_mesh_squared_distance(leaf[None], V, F)[0][0]))
    if exit_at <= max(TIP_REACH * bone, depth):
        return None
    return leaf + min(TIP_LENGTH * bone, exit_at) * direction


def fit_to_mesh(positions, tips, vertices, scale) -> tuple[np.ndarray, np.ndarray, float]:
    """A skeleton brought to the mesh's size: (positions [J, 3], tips [J, 3], the scale used).

    positions [J, 3], tips [J, 3] (NaN where none) in the file's units; vertices [V, 3] the mesh's used vertices.
    ``scale`` a number: positions are multiplied by it (about the origin); "auto": the skeleton (joints and bone
    ends) is scaled so that its extent along its own longest axis is the mesh's along that axis, and moved so that
    the centres of the two bounding boxes meet. The axes are not changed: a BVH must be in the mesh's axes.
    """
    positions = np.asarray(positions, dtype=np.float64)
    tips = np.asarray(tips, dtype=np.float64)
    if scale != "auto":
        return positions * float(scale), tips * float(scale), float(scale)
    points = np.vstack([positions, tips[np.isfinite(tips).all(axis=1)]])
    lo, hi = points.min(axis=0), points.max(axis=0)
    axis = int(np.argmax(hi - lo))
    mesh_lo, mesh_hi = np.min(vertices, axis=0), np.max(vertices, axis=0)
    if hi[axis] - lo[axis] <= 0:        # a single joint, or all at one point: only moved
        factor = 1.0
    else:
        factor = float((mesh_hi[axis] - mesh_lo[axis]) / (hi[axis] - lo[axis]))
    shift = (mesh_lo + mesh_hi) / 2 - factor * (lo + hi) / 2
    return positions * factor + shift, tips * factor + shift, factor


def along_other_bones(P, parents, bones) -> list[int]:
    """The bones (by child joint) among ``bones`` [B] that run along the others: at least INSIDE_FRACTION of
    their BONE_SAMPLES points lie within ALONG x their length of another bone. P [J, 3] joints, parents [J].
    Dropped longest first and judged again, so of two bones that cover each other only the longer goes."""
    from .attach import segment_distances

    t = (np.arange(BONE_SAMPLES) + 0.5) / BONE_SAMPLES
    left = [int(b) for b in bones]
    dropped: list[int] = []
    while len(left) > 1:
        heads, tails = P[parents[left]], P[left]
        lengths = np.linalg.norm(tails - heads, axis=1)
        doubling = []
        for k, b in enumerate(left):
            checkpoint()
            X = heads[k] + t[:, None] * (tails[k] - heads[k])
            others = [i for i in range(len(left)) if i != k]
            near = segment_distances(X, heads[others], tails[others]).min(axis=1) <= ALONG * lengths[k]
            if near.mean() >= INSIDE_FRACTION:
                doubling.append(k)
        if not doubling:
            break
        longest = max(doubling, key=lambda k: lengths[k])
        dropped.append(left.pop(longest))
    return dropped


def split_at_parts(V, F, P, parents, bones, size: float) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """How to split the bones p -> c (by child joint, among ``bones``) whose parent is not in the part of the mesh
    that holds their child: {c: (where the bone leaves the mesh coming from p [3] (p itself if p is outside),
    where it enters the child's part [3])}. The parent heats up to the first point, the child from the second.

    A "part" is a connected piece of the surface, and a point is in it if that piece's winding number there is at
    least 1/2 (a parent on the part's surface counts as in it). The piece of such a bone inside the child's part
    is body around the child, not the parent's: a root bone rising from the ground into the hips (the Fox), a
    prop held in the hand with a joint of its own, a limb made of separate boxes. V [W, 3], F [G, 3]; P [J, 3]; parents [J].
    """
    import igl
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(V)
    graph = coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, 1, axis=1).ravel())), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    face_part = label[F[:, 0]]
    out: dict[int, np.ndarray] = {}
    for k in range(count):
        checkpoint()
        Fk = F[face_part == k]
        if len(Fk) == 0:
            continue
        lo, hi = V[np.unique(Fk)].min(axis=0), V[np.unique(Fk)].max(axis=0)
        near = [int(c) for c in bones if int(c) not in out and np.all(P[c] >= lo) and np.all(P[c] <= hi)]
        if not near:
            continue
        ends = np.array([[c, parents[c]] for c in near])
        X = P[ends.ravel()]
        # A parent on the part's surface (within NEAR_SURFACE, as in inside_fraction) is in it.
        inside = ((igl.fast_winding_number(V, Fk, X) >= 0.5)
                  | (np.sqrt(igl.point_mesh_squared_distance(X, V, Fk)[0]) <= NEAR_SURFACE * size)).reshape(-1, 2)
        for (c, p), (child_in, parent_in) in zip(ends, inside):
            checkpoint()
            if child_in and not parent_in:
                t = np.linspace(0.0, 1.0, 4 * BONE_SAMPLES + 1)
                X = P[c] + t[:, None] * (P[p] - P[c])
                in_child = igl.fast_winding_number(V, Fk, X) >= 0.5
                in_any = igl.fast_winding_number(V, F, X[::-1]) >= 0.5
                out[int(c)] = (X[::-1][np.argmin(in_any) - 1] if in_any[0] else P[p],
                               X[np.argmin(in_child) - 1] if not in_child.all() else X[-1])
    return out
