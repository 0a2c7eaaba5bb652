"""Learn where a four-legged animal's leg joints sit on its legs as the mesh shows them (``autorig.readoff.legs``).

For every example, its legs are measured around its artist's own joints (``legs.measure_legs``), and for
each leg joint the example has:

    height   its height against the leg's (free, the bend's height, top - free) (``legs.joint_features``):
             three numbers per joint by least squares over the examples, a left joint and its mirror image
             pooled (elbows, ``HEIGHT_FROM_FREE``: one number, the examples' median share of ``free``)
    offset   where it sits across the leg's ring at that height, in ring widths (x towards the animal's own
             side, z forward): the median over the examples, so that one odd rig does not move every leg
    ratio    (wrists, ``HEIGHT_FROM_FOOT``) its height as a share of the leg's free height, against the foot's
             size (``legs.foot_features``): three numbers by least squares, and the least and the most share
             of the examples ("range"), beyond which a shape the examples do not hold is not extrapolated

Returns {joint name: {"height": [FEATURES] (only for ``HEIGHT_FROM_LEGS``, ``HEIGHT_FROM_BACK`` and
``HEIGHT_FROM_FREE``), "offset": [ox, oz]}}, with the tail base's rule read off the rump ({"tail_base": {"rump":
[k, m]}}, ``autorig.readoff.rump.learn_rump``), the head's read off the skull behind the snout ({"head": {"skull":
[c, a, k, m]}}, ``autorig.readoff.head.learn_head``), and a report; joints fewer than ``MIN_EXAMPLES`` examples
have, and the paws, are left to the placement.

Which joints take what was chosen by cross-validation over the corpus's species groups (16 animals, 4 folds as
``benchmarks/cross_validation.py`` deals them, each fold's shipped-recipe template with legs learned from the
other folds, axes given; mean error of each joint, % of the height: placement alone -> moved across onto the
leg -> height from the leg too): knees 11.6 -> 9.7 -> 6.1 take both, and so do hocks (7.2 -> 6.9 -> 7.2: the
0 A.D. hocks are as well placed by the template's proportions, within 0.3, but a long-legged animal's are not,
and the sample dog's bend is found at its hock; a bend that took the larger of fore and aft gave 5.9 here and
found the dog's knee instead); shoulders 12.4 -> 9.6 (10.2), hips 13.9 -> 12.2 (12.0), elbows 6.7 -> 6.3 (6.8)
and wrists 8.5 -> 8.0 (9.8) only the move across, their heights being more the artists' habit than the leg's
shape; the paws, which the embedding finds at the leg's end, neither (4.0 -> 4.7).

The wrists' heights were then found to follow the foot (issue 37, 31 animals from four sources): every hoofed
animal's wrist had been placed 5-14 % of its largest extent too low (the carpus sits half-way up the leg) and
every dog's, cat's and bear's 2-6 % too high (the wrist sits just above a long paw), the template's proportions
being the average of both. The foot's length fore and aft tells them apart (``legs.foot_features``): by
``benchmarks/animals.py --templates quadruped --cv species --axes given --turns none``, the wrists went from
5.6 % mean, 14.5 % worst (a stag) to 3.7 % and 9.6 % (a sheep); the dogs' and bears' wrists got 1-4 % worse.

The elbows' heights were then read off the leg too (``HEIGHT_FROM_FREE``): a share of the leg's free height, the
examples' median, stored as a height rule [share, 0, 0]. Kept at the placement's height, a short-legged animal's
elbow (OpenClonk's mooq) stayed above where its leg joins the body. By ``benchmarks/animals.py --templates
quadruped --turns none --axes given`` (31 animals), held out by species / by source: front elbows 4.4 / 4.6 % of
the largest extent mean, 11.2 / 11.6 worst (the puka) -> 3.3 / 2.9 and 6.9 / 7.5 (the goat); the mooq's 7.6 /
8.5 -> 4.9 / 4.2, the giraffe's 11.0 / 8.6 -> 1.1 / 1.2; every anatomy joint 3.49 / 3.84 mean -> 3.37 / 3.65,
worst 13.2 / 14.4 either way (the mooq's head), structures 31/31, no other joint moved. Elbows their artists put
higher or lower than the median share got worse: the bears', the rhino's, the sheep's, the hippo's, the pig's,
the boar's, the glTF Fox's and Quaternius' fox's by 0.4-3.9 % (at most 5.4).
"""
from __future__ import annotations

import numpy as np

MIN_EXAMPLES = 4
# The joints (by name, without side) whose height is read off the leg, and those left alone.
HEIGHT_FROM_LEGS = ("knee", "ankle")
# The leg's roots: their height is the leg's free height plus a share of the back's height above it (the
# examples' median share), one number, where least squares on three features followed the artists' habits.
HEIGHT_FROM_BACK = ("shoulder", "hip")
# The elbows' height is a share of the leg's free height (the examples' median share: [share, 0, 0] on the leg's
# features), one number, so that an elbow stays within the leg's free part. Left at the placement's height, a
# short-legged animal's elbow stayed where the template's proportions put it, above where its leg joins the
# body (OpenClonk's mooq, its artist's elbow at 0.75 of the free height: 7.6 % of its largest extent off held
# out by species, 8.5 % by source; the puka 11.2, 11.6). Measured around the artists' joints (40 elbows of 20
# animals, error of the height in % of the height, mean / worst, held out by species; by source): least
# squares on the three features as the knees' 3.9 / 8.9; 4.0 / 11.8 (the mooq's 9.9 too high), the share
# 3.5 / 10.1; 3.5 / 10.6 (the examples' shares 0.75-1.31, the shipped template's median 0.91).
HEIGHT_FROM_FREE = ("elbow",)
LEFT_ALONE = ("paw",)
# The joints whose height is a share of the leg's free height read off the foot's size (``legs.foot_features``).
HEIGHT_FROM_FOOT = ("wrist",)


def _role(name: str) -> str:
    return name.rsplit("_", 1)[-1]


def learn_legs(examples, per_example: np.ndarray, template) -> tuple[dict, dict]:
    """({joint name: rule}, report) from ``examples`` (``learn.examples.Example``) and their joints in the
    template frame ``per_example`` [N, J, 3]; only the joints each example maps count."""
    from ..readoff.legs import foot_features, joint_features, legs_of, measure_legs

    mirror = template.mirror_of()
    samples: dict[int, list] = {}
    measured = 0
    for example, truth in zip(examples, per_example):
        prepared = example.prepared()
        known = {template.names.index(k) for k in example.key_of if k in template.names}
        for leg in measure_legs(prepared.work_vertices, prepared.work_faces, truth, template):
            if leg is None:
                continue
            measured += 1
            for j in leg.chain[:-1]:
                if j not in known or _role(template.names[j]) in LEFT_ALONE:
                    continue
                y = float(truth[j, 1])
                centre, width = leg.across(y)
                offset = (np.array([truth[j, 0], truth[j, 2]]) - centre) / width * [leg.side, 1.0]
                key = min(j, int(mirror[j]))
                samples.setdefault(key, []).append((joint_features(leg), y, offset, foot_features(leg), leg.free))
    rules = {}
    for key, rows in samples.items():
        if len(rows) < MIN_EXAMPLES:
            continue
        features = np.array([r[0] for r in rows])
        heights = np.array([r[1] for r in rows])
        role = _role(template.names[key])
        rule = {"offset": [round(float(o), 4) for o in np.median(np.array([r[2] for r in rows]), axis=0)]}
        if role in HEIGHT_FROM_LEGS:
            coef = np.linalg.lstsq(features, heights, rcond=None)[0]
        elif role in HEIGHT_FROM_BACK:
            share = (heights - features[:, 0]) / np.maximum(features[:, 2], 1e-3)
            coef = np.array([1.0, 0.0, float(np.median(share))])
        elif role in HEIGHT_FROM_FREE:
            coef = np.array([float(np.median(heights / np.maximum(features[:, 0], 1e-6))), 0.0, 0.0])
        if role in HEIGHT_FROM_LEGS + HEIGHT_FROM_BACK + HEIGHT_FROM_FREE:
            rule = {"height": [round(float(c), 4) for c in coef], **rule}
        elif role in HEIGHT_FROM_FOOT:
            shares = np.array([r[1] / max(r[4], 1e-6) for r in rows])
            coef = np.linalg.lstsq(np.array([r[3] for r in rows]), shares, rcond=None)[0]
            rule = {"ratio": [round(float(c), 4) for c in coef],
                    "range": [round(float(shares.min()), 4), round(float(shares.max()), 4)], **rule}
        for j in {key, int(mirror[key])}:
            rules[template.names[j]] = rule
    from ..readoff.rump import JOINT, learn_rump
    rump, rumps = learn_rump(examples, per_example, template)
    if rump is not None:
        rules[JOINT] = {"rump": rump}
    from ..readoff.head import JOINT as HEAD, learn_head
    head, heads = learn_head(examples, per_example, template)
    if head is not None:
        rules[HEAD] = head
    return rules, {"legs_measured": measured, "rumps_measured": rumps, "heads_measured": heads, "legs_total": len(legs_of(template)) * len(examples),
                   "joints": {template.names[k]: len(v) for k, v in sorted(samples.items())}}
