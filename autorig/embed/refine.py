"""Continuous refinement: from the discrete embedding to every template joint's position.

First every joint of a collapsed chain is put on its reduced bone's sphere path, at the arc-length fraction
its template position has along the chain (a neck and head's, a tail's: at that fraction of the chord from the
chain's start to its tip): the path ends at its tip read off the surface
(``autorig.readoff.tips``: the centroid of the limb's end cap, so the joints before it sit inside the limb,
not at its end), and its zigzag between sphere centres is smoothed out first. Then all joints move together to minimise, with scipy's L-BFGS-B and
an exact gradient, on a smoothed depth (``DistanceField.smooth_depth_and_gradient``: continuous gradient, the same
whichever cells the octree split):

=============  ======  ==================================================================================
term           weight  what it asks
=============  ======  ==================================================================================
depth          1.0     each joint at least as deep in the volume as where it started (centred in its limb);
                       tips (crown, fingertips) no farther out than the surface
inside         4.0     every bone's segment inside the mesh, its joints included
length         1.0     bone lengths as placed on the paths (squared relative change)
direction      1.0     1 - cos(angle) between each bone and the template's (a shoulder beside the chest, not
                       on the spine); a bone whose path points more than 90 degrees from the template's
                       (a hand turned inward across the chest) toward its path's direction in part
                       (``_bone_targets``)
symmetry       0.5     mirrored joints mirror images of each other about the body's mid-plane, each pair as
                       much as the mesh about it is its own mirror image (``pair_symmetry``: a stride's
                       legs, a raised arm are not mirrored; a symmetric body's near-ties are)
anchor         0.2     joints stay near where the embedding put them (squared, per 5% of the height)
=============  ======  ==================================================================================
"""
from __future__ import annotations

import numpy as np

from ..discretize.distance import DistanceField
from ..discretize.graph import SphereGraph
from ..template import Template
from . import Embedding

TERMS = {"depth": 1.0, "inside": 4.0, "length": 1.0, "direction": 1.0, "symmetry": 0.5, "anchor": 0.2}
ANCHOR_UNIT = 0.05
# Points along each solid bone kept inside, its two joints among them: on the octree's depth, whose gradient
# jumps at cell faces, L-BFGS-B stopped short of the minimum with joints inside; on the smoothed depth it goes on,
# and with the inner points alone the elbows of a posed Boudicca's arms bent in front settled just outside.
BONE_SAMPLES = np.linspace(0.0, 1.0, 6)
SMOOTH_ROUNDS = 3   # rounds of smoothing of an embedded path before joints are placed along it
# A mirror pair's symmetry weight: the mesh within SYMMETRY_REACH (heights) of either of its joints is mirrored
# across the mid-plane, and its mean distance to the surface (heights) weighs the pair by
# 1 / (1 + (distance / SYMMETRY_SCALE)^2). A body in its symmetric rest pose is its own mirror image to well
# under a percent of its height; a leg 25 degrees forward in a stride lies some 10 % from where its mirror
# image's is, and the term had pulled both legs of a stride two thirds of the way to each other's mirror image
# (posed corpus bipeds, benchmarks/poses.py: ankles 11 % of the height off).
SYMMETRY_REACH = 0.08
SYMMETRY_SCALE = 0.02
SYMMETRY_SAMPLES = 2000


def place_on_paths(graph: SphereGraph, embedding: Embedding, template: Template, surface,
                   field=None) -> np.ndarray:
    """[J, 3] initial position of every template joint, by arc length along the embedded sphere paths (a
    mid-plane chain that ends at a tip, given the ``surface``: by the fraction of its chord), each
    path smoothed and each tip read off ``surface`` (a ``readoff.tips.Surface`` of the mesh in the graph's
    frame: the centroid of its limb's end cap; None: each path's own end). ``field`` (the distance field, same
    frame): the paths of the mid-plane's chains (spine, neck and head, tail) first centred across the body
    (``readoff.midline.centred_points``), so that which of two mirror-image paths the embedding took (a head
    whose top holds a sphere at each side, an ear or a bun of hair, equally cheap) does not matter."""
    reduced = template.reduced()
    mirror = template.mirror_of()
    positions = np.zeros((len(template.names), 3))
    positions[reduced.joints[0]] = graph.centers[embedding.spheres[0]]
    if field is not None:
        from ..readoff.midline import centred_across, centred_points
        vertices = field.surface_vertices
        root = reduced.joints[0]
        if mirror[root] == root:
            positions[root] = centred_points(positions[root], field.depth, vertices, whole=True)[0]
    # each limb's end (a reduced leaf's joint) -> its sphere's centre
    branches = set(reduced.parents.tolist())
    ends = {int(reduced.chains[k][-1]): graph.centers[embedding.spheres[k]] for k in range(1, len(reduced.joints))
            if k not in branches}
    for k in range(1, len(reduced.joints)):
        chain = reduced.chains[k]
        polyline = graph.centers[embedding.paths[k]]
        on_midline = all(mirror[j] == j for j in chain)
        to_tip = surface is not None and template.is_tip(chain[-1])
        if field is not None and on_midline:
            polyline = centred_points(polyline, field.depth, vertices, whole=True)
        if to_tip:
            tip = surface.tip(polyline[-1], midline=mirror[chain[-1]] == chain[-1])
            if tip is not None and mirror[chain[-1]] != chain[-1] and _at_other_end(tip, polyline[-1], chain[-1],
                                                                                   ends, mirror):
                tip = None
            if tip is not None and _beyond_start(polyline, tip):
                polyline = _end_at(polyline, tip)
        if field is not None and on_midline and template.is_tip(chain[-1]) and len(polyline) > 2:
            # A neck and head's or a tail's path centred across its chord (to its tip), in the mid-plane: a path
            # through the neck took the front of it or the back as the spheres fell (a re-posed MakeHuman body's
            # head 0.74 % of the height apart under 1e-6 noise). A path that winds far from its chord (a curled
            # tail) is left as it is, smoothly, as the placement below does.
            chord = polyline[-1] - polyline[0]
            across = np.array([0.0, -chord[2], chord[1]])
            length = float(np.linalg.norm(chord))
            w = _straightness(float(np.linalg.norm(np.diff(polyline, axis=0), axis=1).sum()), length)
            if length > 0 and np.linalg.norm(across) > 0 and w > 0:
                inner = centred_across(polyline[1:-1], field.depth, across / np.linalg.norm(across), length,
                                       float(np.median(polyline[:, 0])))
                polyline = np.vstack([polyline[:1], polyline[1:-1] + w * (inner - polyline[1:-1]),
                                      polyline[-1:]])
        polyline = _smoothed(polyline)
        seg = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        if to_tip and on_midline:
            # A mid-plane chain that ends at a tip (a neck and head, a tail): its joints placed by how far
            # along the chord from its start to its tip they lie, not by the length of the path up to them.
            # Inside a round head the path takes one route or another between equally good spheres (up the
            # back of the skull, or round the front), and the length of the route moved the neck and head
            # along it (seated MakeHuman bodies: 1.9 and 2.7 % of the height under 1e-6 noise); the chord and
            # the tip, read off the surface, move little. A path that winds far from its chord (a curled
            # tail: 1.3 to 2 times the chord's length) goes back to its own length, smoothly.
            chord = polyline[-1] - polyline[0]
            length = float(np.linalg.norm(chord))
            if length > 0 and arc[-1] > 0:
                along = np.maximum.accumulate(np.clip((polyline - polyline[0]) @ chord / length, 0.0, length))
                w = _straightness(float(arc[-1]), length)
                arc = w * along + (1.0 - w) * arc * (length / arc[-1])
        template_seg = np.linalg.norm(np.diff(template.positions[chain], axis=0), axis=1)
        fractions = np.concatenate([[0.0], np.cumsum(template_seg)]) / template_seg.sum()
        for joint, s in zip(chain[1:], fractions[1:]):
            positions[joint] = _point_at(polyline, arc, s * arc[-1])
    return positions


def _straightness(arc: float, chord: float) -> float:
    """1 for a path at most 1.3 times as long as its chord, 0 from twice on (a curled tail), smooth between."""
    return float(np.clip((2.0 - arc / chord) / 0.7, 0.0, 1.0)) if chord > 0 else 0.0


def _at_other_end(tip: np.ndarray, path_end: np.ndarray, joint: int, ends: dict, mirror) -> bool:
    """Whether a paired limb's ``tip`` [3], read off the surface from its path's end ``path_end`` [3], lies
    nearer the end sphere of another paired limb (``ends`` {end joint: [3]}, but ``joint``'s own and its mirror
    image's) than its path's end: that limb's end, not this one's. A hand pressed into the hip, climbed from the
    hip, read the toes' cap (MakeHuman bodies' wrists 17-22 % of the height off). Hands held together may read
    each other's ends: their mirror pair is not counted. Nor are the mid-plane's ends (a head's, a tail's): a
    head's end sphere may lie anywhere on it (behind a helmet's crest), and a bent arm's tip read up at the
    shoulder lay nearer it than its path's end (0 A.D.'s Boudicca, arms bent: the tip rejected, her thin
    forearms' joints were refined outside the mesh and her right rig scored 0.03)."""
    gap = float(np.linalg.norm(tip - path_end))
    return any(float(np.linalg.norm(tip - centre)) < gap for j, centre in ends.items()
               if j != joint and j != mirror[joint] and mirror[j] != j)


def _beyond_start(polyline: np.ndarray, tip: np.ndarray) -> bool:
    """Whether ``tip`` [3] lies beyond the start of the polyline [P, 3] along its chord (start to end): a limb's
    end, read off the surface, may lie short of its path's end (a path that ran on past the end cap) but not
    behind the limb's start. A climb on a piece whose point nearest the body's core is not where it joins the
    body ran the other way: a hand resting on the hip, its arm a separate piece (0 A.D.), climbed from the
    hand up to the shoulder; a head's cap that reached into a raised arm and the legs, down to the feet."""
    chord = polyline[-1] - polyline[0]
    return float((tip - polyline[0]) @ chord) > 0.0


def _end_at(polyline: np.ndarray, tip: np.ndarray) -> np.ndarray:
    """The polyline [P, 3] cut before its first point at or past ``tip`` [3] (seen along the line from its
    start to the tip: a path may run on past a limb's end cap), then ending at the tip."""
    d = tip - polyline[0]
    beyond = np.flatnonzero((polyline[1:] - polyline[0]) @ d >= d @ d) + 1
    return np.vstack([polyline[:beyond[0]] if beyond.size else polyline, tip])


def _smoothed(polyline: np.ndarray, rounds: int = SMOOTH_ROUNDS) -> np.ndarray:
    """The polyline [P, 3] with each inner point moved half-way to its neighbours' mean, ``rounds`` times,
    its ends kept: the zigzag of a path between packed sphere centres taken out, so that which of two
    neighbouring spheres the path passes matters little to the arc lengths the joints are placed at."""
    out = np.array(polyline, float)
    for _ in range(rounds if len(out) > 2 else 0):
        out[1:-1] = 0.5 * out[1:-1] + 0.25 * (out[:-2] + out[2:])
    return out


def _point_at(polyline: np.ndarray, arc: np.ndarray, s: float) -> np.ndarray:
    if arc[-1] <= 0:
        return polyline[0].copy()
    i = int(np.clip(np.searchsorted(arc, s) - 1, 0, len(arc) - 2))
    t = (s - arc[i]) / max(arc[i + 1] - arc[i], 1e-12)
    return polyline[i] + np.clip(t, 0.0, 1.0) * (polyline[i + 1] - polyline[i])


def pair_symmetry(field, joints: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """[P] in (0, 1]: how nearly the mesh about each mirror pair of ``joints`` [J, 3] (``left`` [P], ``right``
    [P] indices; canonical frame, mid-plane x = 0, one unit tall) is its own mirror image: the surface points
    (``spread`` samples of the mesh's vertices) within ``SYMMETRY_REACH`` of either joint, mirrored across
    x = 0, their mean distance to the surface d (each weighted by a bump falling smoothly to 0 at the reach), and 1 / (1 + (d / SYMMETRY_SCALE)^2); 1 for a pair with no
    surface point that near."""
    out = np.ones(len(left))
    if not len(left):
        return out
    points = field.spread_vertices(SYMMETRY_SAMPLES)
    if not len(points):
        return out
    # Each point counts by a smooth bump of its distance to the nearer joint of the pair, (1 - (d / reach)^2)^2,
    # not all or nothing at the reach: a joint that moves a little then moves the weight a little (a hard edge
    # moved a 0 A.D. Boudicca's wrist 0.7 % of the height under 1e-6 noise).
    near = np.minimum(np.linalg.norm(points[None] - joints[left][:, None], axis=2),
                      np.linalg.norm(points[None] - joints[right][:, None], axis=2)) / SYMMETRY_REACH
    bump = np.clip(1.0 - near ** 2, 0.0, None) ** 2                  # [P, N]
    used = np.flatnonzero(bump.max(axis=0) > 0)
    if not len(used):
        return out
    distance = field.surface_distance(points[used] * [-1.0, 1.0, 1.0])
    count = bump[:, used].sum(axis=1)
    mean = (bump[:, used] @ distance) / np.maximum(count, 1e-12)
    return np.where(count > 0, 1.0 / (1.0 + (mean / SYMMETRY_SCALE) ** 2), 1.0)


def _bone_targets(template_bones: np.ndarray, placed_bones: np.ndarray) -> np.ndarray:
    """[B, 3] unit directions the refinement's direction term turns each bone toward: the template's, to the bit,
    for a bone placed on its path within 90 degrees of it (nearly every bone of a character in the template's
    rest pose); for a bone whose path points farther away (a hand turned inward across the chest;
    ``template_bones`` and ``placed_bones`` [B, 3]) the template's and the path's own, blended by how far past
    90 degrees it points. The template's direction alone had turned the hands of arms bent in front of the chest
    back outward, each wrist pulled past the other hand's (posed MakeHuman bodies: wrists 4-5 % of the height
    off, on the other wrist's side of it). The placed bones are the paths' own, without the tips read off the
    surface: a tip read off short of its path's end (Homer's toes) would point a bone backward, which the
    template's direction is there to mend."""
    ahead = template_bones / np.linalg.norm(template_bones, axis=1, keepdims=True)
    placed = placed_bones / np.maximum(np.linalg.norm(placed_bones, axis=1, keepdims=True), 1e-12)
    keep = np.clip(1.0 + np.einsum("ij,ij->i", ahead, placed), 0.0, 1.0)[:, None]
    blend = keep * ahead + (1.0 - keep) * placed
    blend /= np.maximum(np.linalg.norm(blend, axis=1, keepdims=True), 1e-12)
    return np.where(keep < 1.0, blend, ahead)


def refine(field: DistanceField, initial: np.ndarray, template: Template, max_iterations: int = 200,
           on_paths: np.ndarray | None = None) -> np.ndarray:
    """[J, 3] joint positions after continuous optimisation, starting from ``initial`` [J, 3]. ``on_paths``
    [J, 3]: the joints along the embedded paths without their tips read off (``place_on_paths`` with no
    surface), whose bones' directions the direction term leans toward where they point away from the
    template's (``_bone_targets``); None: the template's directions alone."""
    from scipy.optimize import minimize

    J = len(template.names)
    parents = template.parents
    child = np.flatnonzero(parents >= 0)
    parent = parents[child]
    # Tips sit on the surface on purpose; they neither need depth nor give depth to their bone.
    solid = np.array([not template.is_tip(j) for j in range(J)])
    solid_bone = solid[child]
    target_depth = np.where(solid, np.maximum(field.smooth_depth_and_gradient(initial)[0], 0.0), 0.0)
    rest_length = np.maximum(np.linalg.norm(initial[child] - initial[parent], axis=1), 1e-6)
    template_dir = template.positions[child] - template.positions[parent]
    if on_paths is None:
        template_dir /= np.linalg.norm(template_dir, axis=1, keepdims=True)
    else:
        template_dir = _bone_targets(template_dir, on_paths[child] - on_paths[parent])
    # Mirror pairs, and the mid-plane's own joints as pairs of themselves (a head, a tail end: mirrored, they
    # are to stay where they are). Without the latter a tip on a symmetric body can settle on either side of
    # the plane, whichever the search happens to reach (a 0 A.D. aurochs' head_end 2.5 % of the height left or
    # right when the mesh is turned).
    mirror = template.mirror_of()
    own = [j for j in range(J) if mirror[j] == j]
    left = np.array([i for i, j in template.symmetry] + own, dtype=np.int64)
    right = np.array([j for i, j in template.symmetry] + own, dtype=np.int64)
    flip = np.array([-1.0, 1.0, 1.0])
    pair_weight = np.concatenate([pair_symmetry(field, initial, left[:len(template.symmetry)],
                                                right[:len(template.symmetry)]), np.ones(len(own))])
    scale = max(float(target_depth[solid].max()) if solid.any() else 0.0, 1e-3)

    def objective(flat: np.ndarray) -> tuple[float, np.ndarray]:
        X = flat.reshape(J, 3)
        grad = np.zeros_like(X)
        total = 0.0

        # The field is queried once for the joints and the bones' sample points, smoothed over the finest grid
        # (``smooth_depth_and_gradient``): a depth whose gradient jumps at the octree's cell faces sent
        # L-BFGS-B from the same start to another local minimum as a rounding error split other cells.
        a, b = X[parent[solid_bone]], X[child[solid_bone]]
        s = BONE_SAMPLES[None, :, None]
        pts = (a[:, None, :] * (1 - s) + b[:, None, :] * s).reshape(-1, 3)
        depth, depth_grad = field.smooth_depth_and_gradient(np.vstack([X, pts]))

        # depth: joints no shallower than where they started; tips at least on the surface
        d, gd = depth[:J], depth_grad[:J]
        short = np.maximum(target_depth - d, 0.0) / scale
        total += TERMS["depth"] * np.sum(short ** 2)
        grad += TERMS["depth"] * (-2.0 * short / scale)[:, None] * gd

        # inside: sample points along solid bones stay inside
        d, gd = depth[J:], depth_grad[J:]
        out = np.maximum(-d, 0.0) / scale
        total += TERMS["inside"] * np.sum(out ** 2)
        g_pts = (TERMS["inside"] * 2.0 * out / scale)[:, None] * -gd
        g_pts = g_pts.reshape(len(a), len(BONE_SAMPLES), 3)
        np.add.at(grad, parent[solid_bone], np.sum(g_pts * (1 - s), axis=1))
        np.add.at(grad, child[solid_bone], np.sum(g_pts * s, axis=1))

        # length: bones keep the lengths they had on the paths
        v = X[child] - X[parent]
        length = np.maximum(np.linalg.norm(v, axis=1), 1e-12)
        rel = (length - rest_length) / rest_length
        total += TERMS["length"] * np.sum(rel ** 2)
        g_v = (TERMS["length"] * 2.0 * rel / rest_length / length)[:, None] * v
        np.add.at(grad, child, g_v)
        np.add.at(grad, parent, -g_v)

        # direction: bones point the template's way
        unit = v / length[:, None]
        cos = np.einsum("ij,ij->i", unit, template_dir)
        total += TERMS["direction"] * np.sum(1.0 - cos)
        g_v = -TERMS["direction"] * (template_dir - cos[:, None] * unit) / length[:, None]
        np.add.at(grad, child, g_v)
        np.add.at(grad, parent, -g_v)

        # symmetry: mirror pairs about the plane x = 0 (the body's mid-plane in the canonical frame)
        if len(left):
            diff = X[left] * flip - X[right]
            total += TERMS["symmetry"] * np.sum(pair_weight[:, None] * diff ** 2) / ANCHOR_UNIT ** 2
            g = TERMS["symmetry"] * 2.0 * pair_weight[:, None] * diff / ANCHOR_UNIT ** 2
            np.add.at(grad, left, g * flip)
            np.add.at(grad, right, -g)

        # anchor
        shift = X - initial
        total += TERMS["anchor"] * np.sum(shift ** 2) / ANCHOR_UNIT ** 2
        grad += TERMS["anchor"] * 2.0 * shift / ANCHOR_UNIT ** 2
        return float(total), grad.ravel()

    result = minimize(objective, initial.ravel(), jac=True, method="L-BFGS-B",
                      options={"maxiter": max_iterations})
    return result.x.reshape(J, 3)
