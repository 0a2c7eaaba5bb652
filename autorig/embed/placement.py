"""Learned placement: each joint pulled towards where the template, stretched to the mesh's size, puts it.

The embedding finds the ends of a character's limbs surely (a fingertip, a paw, the tip of a tail stand out)
and its trunk less surely: a quadruped's hips and chest lie in one blob of body, a robed figure's hips in its
skirt. A learned template (``autorig learn``) knows where its joints sit relative to the limb ends, and how far
to trust that over the refined position, joint by joint:

    stretch    per-axis scale [3] of the mesh's bounding box in the template frame against the examples'
               mean box (``extent``), clipped to [1 / MAX_STRETCH, MAX_STRETCH]; the frame is centred on the
               body's mid-plane in x (``orient.mid_plane``) and on the box in z and has the feet at y = 0, so a
               scale about the origin stretches the template over the body (a long-bodied animal, a wide one)
    placed_j = refined_j + alpha_j * (stretch * template_j - refined_j) + box * offset_j

With a learned ``neck`` (the mean neck height of the examples, as a fraction of their height: upright
templates only), the stretch is not one scale in y but two: the template below its neck is scaled onto the
body below the mesh's own neck (``landmarks.neck_fraction``), the template above it onto the head. A
large-headed character's hips, chest and shoulders sit that much lower than a box stretch puts them.

``alpha`` [J] is fitted on rigs of the examples by least squares and clipped to [0, 1] (0: keep the refined
joint; 1: take the template's); leaves keep alpha 0, so the ends the embedding found stay where they are.
``offset`` [J, 3] (optional) is what is still left between those rigs and their truths, on average, as a
fraction of each mesh's bounding box ``box`` [3] (template frame), clipped as the stretch is (a spear held
forward makes a soldier's box five times as deep as his body): where the embedding puts a joint and where
the examples' artists put it differ by a convention (a quadruped's root at the rump, not in the belly's
thickest sphere), and a convention carries over to characters the examples do not include. Tips keep 0.
"""
from __future__ import annotations

import numpy as np

from ..template import Template


MAX_STRETCH = 1.33
MAX_NECK_SHIFT = 0.15    # fraction of the height: the furthest the mesh's neck may move the template's
PULL_BAND = 0.01         # heights: a pull ending less deep than this (and than its joint) is taken in part


def leaves(template: Template) -> np.ndarray:
    """Indices of the template's leaf joints (the ends of the reduced skeleton)."""
    return np.array([j for j, kids in enumerate(template.children) if not kids], dtype=np.int64)


def body_box(extent, mean_extent) -> np.ndarray:
    """[3] the mesh's box ``extent`` [3] clipped to [1 / MAX_STRETCH, MAX_STRETCH] times the examples'
    ``mean_extent`` [3]: what the stretch and the offsets scale by, so that a spear held out does not
    multiply them."""
    mean = np.asarray(mean_extent, float)
    return np.clip(np.asarray(extent, float), mean / MAX_STRETCH, mean * MAX_STRETCH)


def stretched_template(extent: np.ndarray, template: Template, mean_extent, shift=None,
                       neck: float | None = None) -> np.ndarray:
    """[J, 3] the template's joints, moved by a convention's ``shift`` [J, 3] (where its source's examples
    put them on average, against the template's mean of all; None: not moved), scaled per axis by the mesh's
    box ``extent`` [3] (template frame) against the examples' ``mean_extent`` [3]; in y, piecewise about the
    neck where the template has learned one and the mesh's ``neck`` (fraction of its height) is known."""
    mean_extent = np.asarray(mean_extent, float)
    positions = template.positions if shift is None else template.positions + np.asarray(shift, float)
    stretched = positions * (body_box(extent, mean_extent) / mean_extent)
    template_neck = (template.placement or {}).get("neck")
    if template_neck is not None and neck is not None:
        top = body_box(extent, mean_extent)[1]
        stretched[:, 1] = top * neck_heights(stretched[:, 1] / top, template_neck, neck)
    return stretched


def neck_heights(height: np.ndarray, template_neck: float, neck: float) -> np.ndarray:
    """[J] each height [J] (fractions of the body's height, feet 0, top 1) taken from a body whose neck is at
    ``template_neck`` to one whose neck is at ``neck``, keeping the feet and the top: one scale below the
    neck, another above it. The mesh's neck is held within ``MAX_NECK_SHIFT`` of the
    template's, so a misread landmark cannot fold the trunk."""
    neck = float(np.clip(neck, template_neck - MAX_NECK_SHIFT, template_neck + MAX_NECK_SHIFT))
    return np.where(height <= template_neck, height * neck / template_neck,
                    neck + (height - template_neck) * (1 - neck) / max(1 - template_neck, 1e-6))


def learned_placement(joints: np.ndarray, template: Template, extent: np.ndarray, field=None,
                      shift=None, neck: float | None = None) -> np.ndarray:
    """[J, 3] ``joints`` (canonical frame) pulled by the template's learned ``placement`` (unchanged without)
    towards the template moved by a convention's ``shift`` [J, 3] (``convention.convention_shift``);
    ``extent`` [3] is the mesh's bounding box in the same frame, ``neck`` its neck's height as a fraction of
    its height (``landmarks.neck_fraction``; None: unknown). With the distance ``field``, a joint the pull
    would take out of the mesh stays where it was (``inside_share``, by the mesh's exact depth): the
    template's rest pose is not the character's (arms held out where the examples' hang), and a limb's joints
    belong inside the limb."""
    if not template.placement:
        return joints
    alpha = np.asarray(template.placement["alpha"], dtype=float)[:, None]
    target = stretched_template(extent, template, template.placement["extent"], shift, neck)
    placed = joints + alpha * (target - joints)
    if template.placement.get("offset") is not None:
        offset = np.asarray(template.placement["offset"], dtype=float)
        placed = placed + offset * body_box(extent, template.placement["extent"])
    if field is not None:
        share = inside_share(field.exact_depth(placed), field.exact_depth(joints), template)
        placed = joints + share[:, None] * (placed - joints)
    return placed


def inside_share(placed_depth: np.ndarray, depth: np.ndarray, template: Template) -> np.ndarray:
    """[J] how much of its pull each joint takes, by the depth [J] it would be pulled to (``placed_depth``)
    against its own (``depth``; canonical frame, heights, inside > 0); tips all of it. A joint inside takes all
    of a pull that leaves it as deep as it was or ``PULL_BAND`` deep, none of one that ends at the surface or
    out, and between, a smooth step: all or nothing there, a pull ending a hair inside or outside moved a joint
    as far as the pull with a rounding error of the mesh (a seated figure's head 7.5 % of the height towards
    its face). A joint the refinement left outside (an armpit's, a crotch's) takes all of a pull that leaves it
    no shallower, none of one that does (the limit of the step as the joint nears the surface). Mirror images
    take the smaller of their two shares, as the conventions' moves do: one shoulder pulled and its twin not
    made a lopsided rig, and which of them kept its pull turned on where a rounding error of the mesh left
    each (an armoured figure, seated: a shoulder 6 % of the height)."""
    placed_depth, depth = np.asarray(placed_depth, float), np.asarray(depth, float)
    inside = depth > 0
    x = np.clip(placed_depth / np.where(inside, np.minimum(depth, PULL_BAND), 1.0), 0.0, 1.0)
    share = np.where(inside, x * x * (3.0 - 2.0 * x), (placed_depth >= depth).astype(float))
    share[[j for j in range(len(template.names)) if template.is_tip(j)]] = 1.0
    return np.minimum(share, share[template.mirror_of()])


def fit_alpha(refined: list[np.ndarray], truths: list[np.ndarray], extents: list[np.ndarray], template: Template,
              mean_extent, weights: list[np.ndarray] | None = None, shifts: list | None = None,
              necks: list | None = None) -> np.ndarray:
    """[J] the alpha that brings the ``refined`` rigs [N][J, 3] nearest their ``truths`` [N][J, 3] (least
    squares per joint over the examples, with per-example joint ``weights`` [N][J] (0 where unknown));
    ``extents`` [N][3] are the meshes' boxes; ``shifts`` [N][J, 3] each example's convention's shift (or
    None); ``necks`` [N] each mesh's neck height fraction (or None)."""
    J = len(template.names)
    num, den = np.zeros(J), np.zeros(J)
    for n, (R, T) in enumerate(zip(refined, truths)):
        w = np.ones(J) if weights is None else weights[n]
        pull = stretched_template(extents[n], template, mean_extent, None if shifts is None else shifts[n],
                                  None if necks is None else necks[n]) - R
        num += w * np.einsum("ij,ij->i", pull, T - R)
        den += w * np.einsum("ij,ij->i", pull, pull)
    alpha = np.where(den > 1e-12, num / np.maximum(den, 1e-12), 0.0)
    alpha = np.clip(alpha, 0.0, 1.0)
    alpha[leaves(template)] = 0.0
    for i, j in template.symmetry:    # a left joint and its mirror image move alike
        alpha[i] = alpha[j] = (alpha[i] + alpha[j]) / 2
    return alpha


def fit_offset(placed: list[np.ndarray], truths: list[np.ndarray], extents: list[np.ndarray], template: Template,
               mean_extent, weights: list[np.ndarray] | None = None) -> np.ndarray:
    """[J, 3] the mean of what separates the ``placed`` rigs [N][J, 3] (after alpha) from their ``truths``
    [N][J, 3], each as a fraction of its mesh's box ``extents`` [N][3] clipped about the examples'
    ``mean_extent`` [3] (``body_box``), weighted by ``weights`` [N][J] (0 where an example lacks the joint); 0
    for tips and for joints no example has."""
    J = len(template.names)
    total, count = np.zeros((J, 3)), np.zeros(J)
    for n, (P, T) in enumerate(zip(placed, truths)):
        w = np.ones(J) if weights is None else np.asarray(weights[n], float)
        total += w[:, None] * (T - P) / body_box(extents[n], mean_extent)
        count += w
    offset = np.where(count[:, None] > 0, total / np.maximum(count, 1e-12)[:, None], 0.0)
    offset[[j for j in range(J) if template.is_tip(j)]] = 0.0
    mirror = np.array([-1.0, 1.0, 1.0])
    for i, j in template.symmetry:    # a left joint and its mirror image move as each other's mirror images
        offset[i] = (offset[i] + offset[j] * mirror) / 2
        offset[j] = offset[i] * mirror
    return offset
