#!/usr/bin/env python3
"""Fingers on the corpus: the hands stage (``autorig.hands``) against MakeHuman's Mixamo rigs.

Every ``makehuman_*`` folder of the corpus (20 T-posed and 4 A-posed bodies, each with Mixamo's 3 joints per
digit and the rig's own weights) is read twice per hand:

- ``gt``: with the ground-truth wrist and elbow (the hands stage alone), on the GT body skeleton;
- ``e2e``: end to end, ``autorig.rig(mesh, "biped", RigOptions(fingers=True))`` (``--template humanoid``: the
  humanoid's), axes detected.

Scores per hand: finger joint error (joints 1-3 of all five digits; Mixamo has no tip joints) as % of the hand's
length (GT wrist to the GT middle fingertip: the vertex farthest from the wrist among those the artist's weights
give most to Middle3); whether the thumb was found (the digit read as the thumb is nearest the GT thumb, and
all five digits are named right); weight top-1 per finger: of the vertices whose GT top-1 joint is a finger
joint, the share whose predicted top-1 joint is on the same finger (and, stricter, the same joint).

``--fit`` measures the joint fractions of ``autorig.hands.joints.FRACTIONS`` on the corpus as a whole: for each
digit and joint, the fraction of least mean error over all hands read with GT wrists; it prints them with the
error they give, and the leave-one-body-out error (each body scored with fractions fitted on the other 23).

``--short 0.2,0.4,0.6`` reads every hand with the GT wrist and elbow both moved that many forearms back towards
the shoulder (an arm whose end stops short of the hand): how many hands read with fingers, with the thumb right, how
many had their wrist moved out to the hand (``autorig.hands.region.short_wrist_shift``) and how far the limb
reaches past the wrist given (``hand_extent``, in forearms: with 0, the corpus's ``HAND_EXTENT``).

``--shared`` rigs the shared biped-like meshes (no finger ground truth: it prints what each hand was read as).

``--speed MESH`` rigs MESH (e.g. a 30k-face character with fingers: ``tests/hand_samples.py`` makes one) five
times with and five without ``fingers=True`` and prints the medians of the hands stage, the skin weights and
the whole rig.

    PYTHONPATH=. python benchmarks/hands.py [--corpus DIR] [--fit] [--no-e2e] [--template T] [--shared] [--speed MESH]
                                            [--short S,...]
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import time

import numpy as np

from autorig.hands.names import FINGERS
from autorig.hands.stage import read_fingers, skin_with_fingers
from autorig.hands.digits import read_hand
from autorig.hands.joints import FRACTIONS, along_digit
from autorig.hands.region import LIMB_REACH, hand_extent, hand_piece, hand_surface
from autorig.input.mesh import load_mesh

SIDES = {"left": "Left", "right": "Right"}


def load_body(folder):
    """(vertices, faces, gt {short Mixamo name: [3]}, names [J], parents [J], W [V, J], rest pose) of one body."""
    meta = json.load(open(os.path.join(folder, "joints.json")))
    V, F = load_mesh(os.path.join(folder, "mesh.obj"))
    names = [j["name"].split(":")[-1] for j in meta["joints"]]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[j["parent"].split(":")[-1]] if j["parent"] else -1 for j in meta["joints"]]
    gt = {n: np.array(j["position"], float) for n, j in zip(names, meta["joints"])}
    w = np.load(os.path.join(folder, "weights.npz"))
    order = [index[str(n).split(":")[-1]] for n in w["joint_names"]]
    W = np.zeros((len(V), len(names)))
    W[:, order] = w["weights"]
    return V, F, gt, names, parents, W, meta.get("rest_pose", "T")


def middle_tip(V, W, names, gt, S):
    """[3] the GT middle fingertip of side S ("Left"/"Right"): the farthest from the wrist of the vertices
    whose GT top-1 joint is its Middle3."""
    own = W.argmax(axis=1) == names.index(f"{S}HandMiddle3")
    pts = V[own]
    return pts[np.argmax(np.linalg.norm(pts - gt[f"{S}Hand"], axis=1))]


def gt_body(V, W, gt, names, parents):
    """The GT skeleton without its fingers, in the hands stage's names: (names, parents, joints [J, 3])."""
    body = [i for i, n in enumerate(names) if not any(f in n for f in ("Thumb", "Index", "Middle", "Ring", "Pinky"))]
    rename = {f"{S}Hand": f"{s}_wrist" for s, S in SIDES.items()} | {f"{S}ForeArm": f"{s}_elbow"
                                                                     for s, S in SIDES.items()}
    out_names = [rename.get(names[i], names[i]) for i in body]
    old_to_new = {i: k for k, i in enumerate(body)}
    out_parents = [old_to_new.get(parents[i], -1) for i in body]
    joints = [gt[names[i]] for i in body]
    for s, S in SIDES.items():
        out_names.append(f"{s}_hand_end")
        out_parents.append(out_names.index(f"{s}_wrist"))
        joints.append(middle_tip(V, W, names, gt, S))
    return out_names, np.array(out_parents), np.array(joints)


def score(V, W, gt, names, rig_names, rig_joints, rig_weights, status):
    """Per-side scores {side: {...}} of a rig with fingers against the GT."""
    index = {n: i for i, n in enumerate(rig_names)}
    gt_top = W.argmax(axis=1)
    top = rig_weights.argmax(axis=1)
    out = {}
    for s, S in SIDES.items():
        length = float(np.linalg.norm(middle_tip(V, W, names, gt, S) - gt[f"{S}Hand"]))
        row = {"status": status.get(s, "none"), "length": length}
        gt_finger = {names.index(f"{S}Hand{f.capitalize()}{k}"): (f, k) for f in FINGERS for k in (1, 2, 3)}
        if row["status"] == "fingers":
            errors = {f: [float(np.linalg.norm(rig_joints[index[f"{s}_{f}{k}"]] - gt[f"{S}Hand{f.capitalize()}{k}"]))
                          / length for k in (1, 2, 3)] for f in FINGERS}
            row["errors"] = errors
            # Each digit named right: its tip is nearest its own GT finger's last joint.
            nearest = {f: min(FINGERS, key=lambda g: np.linalg.norm(rig_joints[index[f"{s}_{f}_end"]]
                                                                    - gt[f"{S}Hand{g.capitalize()}3"]))
                       for f in FINGERS}
            row["thumb"] = nearest["thumb"] == "thumb"
            row["all_named"] = all(nearest[f] == f for f in FINGERS)
            on_finger = np.isin(gt_top, list(gt_finger))
            finger_of = {index[f"{s}_{f}{k}"]: (f, k) for f in FINGERS for k in (1, 2, 3)}
            got = [finger_of.get(int(t)) for t in top[on_finger]]
            want = [gt_finger[int(t)] for t in gt_top[on_finger]]
            row["top1_finger"] = float(np.mean([g is not None and g[0] == w[0] for g, w in zip(got, want)]))
            row["top1_joint"] = float(np.mean([g == w for g, w in zip(got, want)]))
        else:
            row["thumb"] = False
        out[s] = row
    return out


def run_gt(body):
    """Scores of the hands stage on the GT body skeleton; also the stage's own time."""
    V, F, gt, names, parents, W, _ = body
    b_names, b_parents, b_joints = gt_body(V, W, gt, names, parents)
    t0 = time.perf_counter()
    fingers = read_fingers(V, F, b_names, b_joints)
    seconds = time.perf_counter() - t0
    weights = skin_with_fingers(V, F, b_joints, b_parents, b_names, fingers)
    r_names, _, r_joints, _ = fingers.appended(b_names, b_parents, b_joints, weights)
    return score(V, W, gt, names, r_names, r_joints, weights, fingers.status), seconds


def run_e2e(folder, body, template="biped"):
    """Scores of ``autorig.rig(mesh, template, fingers=True)``, and the hands stage's time in it."""
    import autorig
    V, F, gt, names, _, W, _ = body
    rig = autorig.rig(os.path.join(folder, "mesh.obj"), template, autorig.RigOptions(fingers=True))
    return (score(V, W, gt, names, rig.names, rig.joints, rig.weights, rig.info.get("hands", {})),
            rig.timings.get("hands", 0.0))


def summary(label, rows):
    """One printed block of scores over all hands of ``rows`` [(body, pose, {side: row})]."""
    hands = [(b, p, r) for b, p, sides in rows for r in sides.values()]
    found = [r for _, _, r in hands if r["status"] == "fingers"]
    errs = np.array([e for r in found for f in FINGERS for e in r["errors"][f]]) * 100
    print(f"\n{label}: {len(found)}/{len(hands)} hands read with fingers; thumb found on "
          f"{sum(r['thumb'] for _, _, r in hands)}/{len(hands)}; all five digits named right on "
          f"{sum(r.get('all_named', False) for _, _, r in hands)}/{len(hands)}")
    if not found:
        return
    print(f"  finger joint error, % of hand length: mean {errs.mean():.1f}, median {np.median(errs):.1f}, "
          f"90th pct {np.percentile(errs, 90):.1f}, worst {errs.max():.1f}")
    for f in FINGERS:
        per = np.array([r["errors"][f] for r in found]) * 100
        print(f"    {f:7s} joints 1/2/3: " + " / ".join(f"{m:.1f}" for m in per.mean(axis=0)))
    for pose in ("T", "A"):
        sub = [r for _, p, r in hands if p == pose and r["status"] == "fingers"]
        if sub:
            e = np.array([x for r in sub for f in FINGERS for x in r["errors"][f]]) * 100
            print(f"  {pose}-posed bodies: {len(sub)} hands, joint error mean {e.mean():.1f} %, weight top-1 per "
                  f"finger {100 * np.mean([r['top1_finger'] for r in sub]):.1f} %")
    print(f"  weight top-1 per finger: mean {100 * np.mean([r['top1_finger'] for r in found]):.1f} %, worst hand "
          f"{100 * min(r['top1_finger'] for r in found):.1f} %; per joint (stricter) "
          f"{100 * np.mean([r['top1_joint'] for r in found]):.1f} %")


def fit(bodies):
    """Print, for each digit and joint, the fraction u of least mean error over all hands (GT wrists), and
    the leave-one-body-out error."""
    grid = np.round(np.arange(-1.0, 0.951, 0.01), 2)
    err, owner = [], []                        # err: [hands, 5, 3, U] as a fraction of the hand's length
    for b, (folder, body) in enumerate(bodies):
        V, F, gt, names, _, W, _ = body
        for s, S in SIDES.items():
            wrist = gt[f"{S}Hand"]
            surface = hand_surface(V, F, wrist, gt[f"{S}ForeArm"])
            reading = read_hand(surface, s)
            if reading.status != "fingers":
                continue
            length = np.linalg.norm(middle_tip(V, W, names, gt, S) - wrist)
            e = np.zeros((5, 3, len(grid)))
            for d, (f, digit) in enumerate(zip(FINGERS, reading.digits)):
                path = np.array([along_digit(surface, digit, wrist, u) for u in grid])
                for k in range(3):
                    e[d, k] = np.linalg.norm(path - gt[f"{S}Hand{f.capitalize()}{k + 1}"], axis=1) / length
            err.append(e)
            owner.append(b)
    err, owner = np.array(err), np.array(owner)
    best = err.mean(axis=0).argmin(axis=2)
    print("FRACTIONS = {")
    for d, f in enumerate(FINGERS):
        print(f'    "{f}": ({", ".join(f"{grid[best[d, k]]:.2f}" for k in range(3))}),')
    print("}")
    fitted = np.take_along_axis(err, best[None, :, :, None], axis=3)[..., 0]
    print(f"fitted on all {len(err)} hands: mean joint error {100 * fitted.mean():.1f} % of the hand's length")
    cv = []
    for b in np.unique(owner):
        rest = err[owner != b].mean(axis=0).argmin(axis=2)
        cv.append(np.take_along_axis(err[owner == b], rest[None, :, :, None], axis=3)[..., 0])
    print(f"leave-one-body-out: mean joint error {100 * np.concatenate(cv).mean():.1f} %")
    now = np.array([[int(np.argmin(np.abs(grid - FRACTIONS[f][k]))) for k in range(3)] for f in FINGERS])
    print(f"with the shipped FRACTIONS: {100 * np.take_along_axis(err, now[None, :, :, None], axis=3).mean():.1f} %")


def short(bodies, shifts):
    """Print, for each shift s (forearms), how many hands read with fingers and with the thumb right when the GT
    wrist and elbow are both moved s forearms back along the forearm, and which did not read."""
    for s in shifts:
        read, thumbs, moved, extents, missed = 0, 0, 0, [], []
        for folder, (V, F, gt, names, parents, W, _) in bodies:
            b_names, b_parents, b_joints = gt_body(V, W, gt, names, parents)
            for side in SIDES:
                wrist, elbow = b_names.index(f"{side}_wrist"), b_names.index(f"{side}_elbow")
                b_joints[[wrist, elbow]] -= s * (b_joints[wrist] - b_joints[elbow])
            fingers = read_fingers(V, F, b_names, b_joints)
            moved += len(fingers.moved)
            for side in SIDES:
                wrist, elbow = (b_joints[b_names.index(f"{side}_{j}")] for j in ("wrist", "elbow"))
                extents.append(hand_extent(hand_piece(V, F, wrist, elbow, reach=LIMB_REACH), wrist, elbow))
            weights = np.zeros((len(V), len(b_names) + len(fingers.names)))   # only the joints are scored here
            r_names, _, r_joints, _ = fingers.appended(b_names, b_parents, b_joints, weights)
            for side, row in score(V, W, gt, names, r_names, r_joints, weights, fingers.status).items():
                read += row["status"] == "fingers"
                thumbs += row["thumb"]
                if row["status"] != "fingers":
                    missed.append(f"{os.path.basename(folder)} {side} {row['status']}")
        total = 2 * len(bodies)
        print(f"wrist and elbow {s:.2f} forearms short: {read}/{total} read with fingers, thumb {thumbs}/{total}, "
              f"wrist moved out on {moved}; the limb reaches {np.median(extents):.2f} forearms past the wrist "
              f"(median; {min(extents):.2f}-{max(extents):.2f})" + (f"; not read: {', '.join(missed)}" if missed else ""))


def speed(mesh, runs=5):
    """Print the medians of the hands stage, the skin weights and the whole rig of ``mesh``, with and without
    fingers, over ``runs`` alternating runs."""
    import autorig
    times = {False: [], True: []}
    for _ in range(runs):
        for fingers in (False, True):
            start = time.perf_counter()
            rig = autorig.rig(mesh, "biped", autorig.RigOptions(fingers=fingers))
            times[fingers].append((rig.timings.get("hands", 0.0), rig.timings["skin weights"],
                                   time.perf_counter() - start))
    print(f"{mesh}: {len(rig.faces)} faces, hands {rig.info.get('hands')}")
    for fingers, rows in times.items():
        hands, heat, total = np.median(np.array(rows), axis=0)
        print(f"  fingers={fingers!s:5s}: hands stage {1000 * hands:.0f} ms, skin weights {1000 * heat:.0f} ms, "
              f"whole rig {total:.2f} s (median of {runs})")


SHARED_BIPEDS = ("meshes/armadillo.obj", "meshes/beast.obj", "meshes/cheburashka.obj", "meshes/homer.obj",
                 "meshes/ogre.obj", "meshes/sydney.obj", "rigged/CesiumMan/mesh.obj", "rigged/RiggedFigure/mesh.obj")


def shared(data):
    """Print how each hand of the shared biped-like meshes was read (biped + fingers), and the stage's time."""
    import autorig
    for rel in SHARED_BIPEDS:
        path = os.path.join(data, rel)
        if not os.path.exists(path):
            continue
        rig = autorig.rig(path, "biped", autorig.RigOptions(fingers=True))
        print(f"{rel:32s} {len(rig.faces):7d} faces  hands {rig.info['hands']}  "
              f"stage {1000 * rig.timings['hands']:.0f} ms")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--corpus", default=os.path.join(os.path.dirname(__file__), "..", "..", "corpus"))
    parser.add_argument("--fit", action="store_true", help="measure the joint fractions on the corpus")
    parser.add_argument("--no-e2e", action="store_true", help="only with the GT wrists and elbows")
    parser.add_argument("--speed", metavar="MESH", help="time the hands stage on MESH instead")
    parser.add_argument("--shared", action="store_true", help="what the shared meshes' hands are read as")
    parser.add_argument("--short", help="comma-separated shifts (forearms) of the GT wrist and elbow towards the "
                                        "shoulder: how many hands still read")
    parser.add_argument("--template", default="biped", help="end to end with this template (biped, humanoid)")
    parser.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    args = parser.parse_args()
    if args.shared:
        shared(args.data)
        return
    if args.speed:
        speed(args.speed)
        return
    folders = sorted(glob.glob(os.path.join(args.corpus, "makehuman_*")))
    if not folders:
        raise SystemExit(f"no makehuman_* folders under {args.corpus}")
    bodies = [(f, load_body(f)) for f in folders]
    if args.fit:
        fit(bodies)
        return
    if args.short:
        short(bodies, [float(x) for x in args.short.split(",")])
        return
    gt_rows, e2e_rows, stage = [], [], []
    for folder, body in bodies:
        scores, seconds = run_gt(body)
        gt_rows.append((os.path.basename(folder), body[-1], scores))
        stage.append(seconds)
        if not args.no_e2e:
            scores, seconds = run_e2e(folder, body, args.template)
            e2e_rows.append((os.path.basename(folder), body[-1], scores))
    summary("GT wrists and elbows given", gt_rows)
    if e2e_rows:
        summary(f"end to end ({args.template} + --fingers)", e2e_rows)
    print(f"\nhands stage (both hands, read_fingers): median {1000 * np.median(stage):.0f} ms per body")


if __name__ == "__main__":
    main()
