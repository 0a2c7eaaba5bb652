"""Mid-plane joints centred across the body: a continuous rule for the side-to-side coordinate.

A joint the template puts on the body's mid-plane (the hips, the spine, the neck, the head, a tail) lies in
the trunk's medial *sheet*: every point of a flattened torso's mid-surface is as centred as its neighbour in
depth, so which sphere the embedding takes there is a near-tie that the smallest change of the mesh can flip,
and the joint jumps sideways with it (a hippopotamus's head by 3.4 % of the height under 1e-6 noise). The
side-to-side coordinate is read off the shape instead: the middle of the chord across the body, along the
left-right axis, through the joint, each point of the chord weighted by its depth squared (the chord's ends
weigh nothing, so the middle moves as little as the surface does). A symmetric body's chord is centred on its
mid-plane; a tail swung to one side keeps its own middle. A joint at the surface has no chord of its own to
read (outside, which run to take would be a choice): there it stays as it is, and deeper it is moved the more
of the way to its chord's middle the deeper it lies against the way's length, all of it once it lies as deep
as the way is long or ``FULL_DEPTH`` of the height deep (a seated MakeHuman body's head joint, pulled to the
skin, was centred or not as a rounding error fell: 3 % of the height to one side).
"""
from __future__ import annotations

import numpy as np

SAMPLES = 257          # samples of the depth along each chord, across the whole box
FULL_DEPTH = 0.02      # fraction of the height: a joint this deep (past a sample) is centred all the way
AXIS = 0               # the canonical frame's left-right axis


def chord_middle(depth, point: np.ndarray, lo: float, hi: float, samples: int = SAMPLES) -> float | None:
    """The middle, along x, of the inside run of the line through ``point`` [3] parallel to x that holds the
    point: the run's samples' mean x weighted by their depth squared (0 at the run's ends, so the sum moves as
    little as the surface does, and a thin part the run reaches at one side, an arm beside a neck, weighs
    little). None when the point lies outside (which run to take would be a choice, not a reading).
    depth: the signed depth of points [N, 3] (> 0 inside); lo, hi: the box's extent along x."""
    xs = np.linspace(lo, hi, samples)
    line = np.repeat(np.asarray(point, float)[None, :], samples, axis=0)
    line[:, AXIS] = xs
    d = depth(line)
    i = int(np.clip(np.searchsorted(xs, point[AXIS]), 1, samples - 1))
    i = i if d[i] >= d[i - 1] else i - 1          # the nearer-inside of the two samples around the point
    if d[i] <= 0 or depth(np.asarray(point, float)[None, :])[0] <= 0:
        return None
    return run_middle(d, i, xs)


def run_middle(d: np.ndarray, i: int, at: np.ndarray) -> float:
    """The middle of the inside run of samples (depths ``d`` [S], > 0 inside, at places ``at`` [S] along the
    line) that holds sample ``i``: their places' mean weighted by their depth squared."""
    inside = d > 0
    a = i - int(np.argmin(inside[i::-1])) + 1 if not inside[:i + 1].all() else 0
    b = i + int(np.argmin(inside[i:])) if not inside[i:].all() else len(d)
    w = d[a:b] ** 2
    return float(at[a:b] @ w / w.sum())


def centred_across(points: np.ndarray, depth, direction: np.ndarray, span: float, x: float | None = None,
                   samples: int = SAMPLES) -> np.ndarray:
    """[N, 3] ``points`` each moved along the unit ``direction`` [3] to the middle of the inside run, along it,
    of the line through the point (as ``chord_middle`` reads it along x: depth squared weights, the run that
    holds the point, or for a point outside the nearest), sampled ``span`` either side of it; a line wholly
    outside leaves its point. x: the lines sampled at this x, not the points' own (a chain's, on the
    mid-plane, whose points were not all centred: one near the surface at the back of a skull kept its side,
    and its line ran through another part of the head)."""
    out = np.array(points, float).reshape(-1, 3)
    if not len(out):
        return out
    direction = np.asarray(direction, float)
    ts = np.linspace(-span, span, samples)
    lines = out[:, None, :] + ts[None, :, None] * direction
    if x is not None:
        lines[:, :, AXIS] = x
    depths = np.asarray(depth(lines.reshape(-1, 3)), float).reshape(len(out), samples)
    for j, d in enumerate(depths):
        runs = np.flatnonzero(d > 0)
        if not len(runs):
            continue
        i = int(runs[np.argmin(np.abs(runs - samples // 2))])      # the point's run, or the nearest
        out[j] = out[j] + run_middle(d, i, ts) * direction
    return out


def centred(joints: np.ndarray, template, depth, vertices: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` (canonical frame) with each mid-plane joint but the tips (which lie on the surface,
    where the chord vanishes) moved along x to the middle of the body's chord through it. depth: the field's
    signed depth of points [N, 3]; vertices [V, 3] the mesh's, in the same frame (the chords span their box)."""
    out = np.array(joints, float)
    mirror = template.mirror_of()
    mid = [j for j in range(len(out)) if mirror[j] == j and not template.is_tip(j)]
    if mid:
        out[mid] = centred_points(out[mid], depth, vertices)
    return out


def centred_points(points: np.ndarray, depth, vertices: np.ndarray, whole: bool = False) -> np.ndarray:
    """[N, 3] ``points`` (canonical frame) each moved along x towards the middle of the body's chord through it,
    as ``centred`` moves a mid-plane joint: all the way once it lies deep enough, less the nearer it lies to the
    surface, not at all outside. whole: all the way wherever the chord has a middle (sphere centres, which lie
    inside by their making: the end of a head's path, shallow at the top of the head, went 0.036 of the height
    to one side or the other as the embedding took a sphere on one side of the head or its mirror image)."""
    out = np.array(points, float).reshape(-1, 3)
    margin = 0.02 * float(np.ptp(vertices[:, AXIS]))
    lo, hi = float(vertices[:, AXIS].min()) - margin, float(vertices[:, AXIS].max()) + margin
    step = (hi - lo) / (SAMPLES - 1)
    full = FULL_DEPTH * float(np.ptp(vertices[:, 1]))
    inside = np.asarray(depth(out), float) - (0.0 if whole else step)
    for j in np.flatnonzero(inside > 0):
        middle = chord_middle(depth, out[j], lo, hi)
        if middle is None:
            continue
        # A joint within a sample of the surface may lie outside the chord's samples (no middle to read). Deeper,
        # it is moved a share of the way that grows with its depth against the way's length, so that a joint a
        # hair deeper moves by little more than a hair; all of it from a depth as large as the way, or FULL_DEPTH
        # of the height, on (a flattened trunk's mid-plane joint, shallow but far off its middle, is centred).
        way = abs(middle - out[j, AXIS])
        x = min(inside[j] / min(way, full), 1.0) if way > 0 and not whole else 1.0
        out[j, AXIS] = middle if x == 1.0 else out[j, AXIS] + x * x * (3.0 - 2.0 * x) * (middle - out[j, AXIS])
    return out
