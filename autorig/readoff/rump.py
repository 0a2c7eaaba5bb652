"""The tail's base read off the mesh: where the trunk ends behind the hind legs, not where a box puts it.

The placement puts a four-legged template's ``tail_base`` by the mesh's bounding box (stretched template plus
a learned offset); a bushy tail, a tail hanging down or none at all moves the box's back end, not the rump.
The 0 A.D. artists put it at the rump's end, near the back's line (on a cow, a pig or a rhino on the surface,
on a fox where its tail leaves the body), so it is measured from the trunk's own depth instead. In the
canonical frame (+y up, one unit tall, facing +z), on the body's mid-plane (the x half-way between the hind
legs' roots), over a grid of ``STEP``:

    depth(z)   the deepest point of the mid-plane's column at z (the trunk's half-thickness there)
    trunk      the largest depth(z) between the hind and the front legs' roots
    end        going back from the hind legs, the last z whose column is still at least ``HALF`` the
               trunk's depth: a tail, however long or low it hangs, leaves the trunk thinner than half of it
               (0 A.D.'s fox, the bushiest, 0.30; the glTF sample Fox's brush is 0.7 deep, behind a root of 0.4)
    middle     the height of that column's deepest point

and the joint goes to (x, middle + m * trunk, end + k * trunk), k and m the medians over the examples
(``learn_rump``). Cross-validated over the corpus's species groups (``benchmarks/cross_validation.py``) the
tail base's error fell from 14.3 % of the height on average (the box's) to 8.7 % (docs/tutorials/learn.md).
The template's ``legs`` carries the rule as ``{"tail_base": {"rump": [k, m]}}``; a template without it, or a
mesh whose rump cannot be measured (no legs, no trunk deeper than the grid's step), keeps its joint.
"""
from __future__ import annotations

import numpy as np

HALF = 0.5
STEP = 0.01
JOINT = "tail_base"
MIN_EXAMPLES = 4


def measure_rump(depth, vertices: np.ndarray, joints: np.ndarray, template) -> tuple[float, ...] | None:
    """(x, end, middle, trunk) of the mesh's rump (module docstring), from its signed ``depth`` (a function of
    points [N, 3] -> [N], > 0 inside), its ``vertices`` [V, 3] and the legs' roots in ``joints`` [J, 3] (all
    in the canonical frame); None without two legs before and behind, or without a trunk."""
    from .legs import legs_of
    roots = np.array([joints[chain[0]] for chain in legs_of(template)]).reshape(-1, 3)
    if len(roots) < 4:
        return None
    middle_z = float(np.median(roots[:, 2]))
    hind, front = roots[roots[:, 2] < middle_z], roots[roots[:, 2] >= middle_z]
    if not len(hind) or not len(front):
        return None
    x = float(hind[:, 0].mean())
    hind_z, front_z = float(hind[:, 2].mean()), float(front[:, 2].mean())
    low, high = float(vertices[:, 1].min()), float(vertices[:, 1].max())
    Z = np.arange(float(vertices[:, 2].min()), front_z, STEP)
    Y = np.arange(low, high, STEP)
    if len(Z) < 2 or len(Y) < 2 or not np.any(Z >= hind_z):
        return None
    d = midplane_depths(depth, x, Z, Y)
    column = d.max(axis=1)                                           # [Z]
    trunk = float(column[Z >= hind_z].max())
    if trunk < STEP:
        return None
    # Back from the hind legs while the columns stay half as deep as the trunk: a brush of a tail behind a
    # narrower root (the glTF sample Fox's is 0.7 of its trunk's depth) is not the trunk.
    i = int(np.searchsorted(Z, hind_z))
    while i > 0 and column[i - 1] >= HALF * trunk:
        i -= 1
    return x, float(Z[i]), float(Y[int(np.argmax(d[i]))]), trunk


def midplane_depths(depth, x: float, Z: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """[len(Z), len(Y)] signed ``depth`` (points [N, 3] -> [N]) on the plane at ``x``, at every (Y, Z) of the
    grids Z [nz] and Y [ny]: the columns the rump and the snout are read from."""
    zz, yy = np.meshgrid(Z, Y, indexing="ij")
    return np.asarray(depth(np.c_[np.full(zz.size, x), yy.ravel(), zz.ravel()]), float).reshape(len(Z), len(Y))


def ruled_measurement(joints: np.ndarray, template, joint: str, key: str, measure, depth, vertices: np.ndarray):
    """(the template's learned rule ``legs[joint][key]``, ``measure(depth, vertices, joints, template)``) for the
    [J, 3] ``joints``, or None without the joint, the rule or the measurement."""
    rule = (template.legs or {}).get(joint, {}).get(key)
    if rule is None or joint not in template.names:
        return None
    measured = measure(depth, vertices, joints, template)
    return None if measured is None else (rule, measured)


def read_rump(joints: np.ndarray, template, depth, vertices: np.ndarray) -> np.ndarray:
    """[J, 3] ``joints`` with the tail's base moved by the template's learned rule to the mesh's rump
    (``measure_rump``); unchanged without the rule or the measurement."""
    found = ruled_measurement(joints, template, JOINT, "rump", measure_rump, depth, vertices)
    if found is None:
        return joints
    rule, (x, end, middle, trunk) = found
    out = joints.copy()
    out[template.names.index(JOINT)] = [x, middle + rule[1] * trunk, end + rule[0] * trunk]
    return out


def measured_examples(examples, per_example: np.ndarray, template, joint: str, measure):
    """(truth [J, 3], measurement) of each of ``examples`` (``learn.examples.Example``, their joints in the
    template frame ``per_example`` [N, J, 3]) that maps ``joint`` and whose mesh ``measure(depth, vertices,
    joints, template)`` measures (not None), the depth being the working mesh's signed distance."""
    from ..discretize.surface import SurfaceQuery
    for example, truth in zip(examples, per_example):
        if joint not in example.key_of:
            continue
        prepared = example.prepared()
        query = SurfaceQuery(prepared.work_vertices, prepared.work_faces)
        measured = measure(lambda p: query.closest(p)[0], prepared.work_vertices, truth, template)
        if measured is not None:
            yield truth, measured


def learn_rump(examples, per_example: np.ndarray, template) -> tuple[list[float] | None, int]:
    """([k, m] or None, how many examples measured): the medians over ``examples`` (``learn.examples.Example``,
    their joints in the template frame ``per_example`` [N, J, 3]) that have the tail's base and a rump, of how
    far behind the rump's end (k) and above its middle (m) their artists put it, in trunk depths. Medians, so
    that one species' odd joint (0 A.D.'s aurochs puts it deep in the rump) does not move every animal's."""
    if JOINT not in template.names:
        return None, 0
    j = template.names.index(JOINT)
    rows = [((truth[j, 2] - end) / trunk, (truth[j, 1] - middle) / trunk)
            for truth, (_, end, middle, trunk) in measured_examples(examples, per_example, template, JOINT,
                                                                     measure_rump)]
    if len(rows) < MIN_EXAMPLES:
        return None, len(rows)
    return [round(float(v), 4) for v in np.median(np.array(rows), axis=0)], len(rows)
