#!/usr/bin/env python3
"""How a rig deforms: ground-truth characters posed with the artist's rig and with autorig's, side by side.

    python benchmarks/deformation.py [--shared ../shared] [--corpus ../corpus] [--per-source N] [--frames K]
                                     [--only NAME ...] [--no-tilt]

For each ground-truth character (``shared/data/rigged/*`` with a template map, the training corpus
``shared/data/train/*`` and the corpus ``--corpus`` by source, ``--per-source`` of each spread evenly over
its names in order) autorig rigs the mesh (``autorig.pipeline.rig`` with the ground truth's axes, so that orientation is not
what is judged) and both rigs are posed by the same motions, joints matched by template name (the artist's
joints through the example's ``biped_map`` / ``quadruped_map``, as ``autorig.learn`` reads them):

* single-joint bends: every limb joint (shoulders, elbows, hips, knees, neck, spine; a quadruped's legs)
  turned 60 degrees about the character's left axis (a shoulder about its front axis: the arm raised), the
  joint's whole subtree following rigidly, each rig about its own joint;
* the shared BVH clips (bipeds), ``K`` frames of each spread evenly, retargeted onto the artist's rig by
  ``autorig.pose.retarget``, and autorig's rig given the same world rotation joint by joint (its root moved as
  the artist's), so that both take one motion whatever their bones' rest directions (the head's tilt, which
  depends on them, is measured apart).

Posed vertices are compared as a fraction of the height: mean, 95th percentile and worst over vertices and
poses. Then checks that need no artist, for both rigs:

* ``far``: pieces (connected parts after welding, other than the largest) no larger than a tenth of the height
  whose dominant joint is neither the owner of the bone nearest the piece's centre nor its parent or child;
* ``tear``: the worst stretch of an edge in any pose (posed length minus rest length), % of the height;
* ``vol``: volume lost at the elbow and knee bends (signed volume of the posed mesh against rest, % of the
  volume of the whole mesh; a limb's collapse shows as a loss);
* ``tilt``: with ``--tilt`` (default on), the shared meshes walking (``delfem2_walk.bvh``): the head's tilt
  from upright (the angle between the posed and rest up vector carried by the head joint's rotation), the
  worst over the frames where the clip's own head stays within 10 degrees.

Prints one line per character and one per source (mean of the means, mean of the 95th percentiles, the worst).
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from autorig.exchange.bvh import read_bvh  # noqa: E402
from autorig.pipeline import RigOptions, rig  # noqa: E402
from autorig.show.pose import retarget, skin  # noqa: E402
from autorig.result import Rig  # noqa: E402

BEND_DEGREES = 60.0
BENDS = {"biped": ["left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_hip", "right_hip",
                   "left_knee", "right_knee", "neck", "spine"],
         "quadruped": ["front_left_shoulder", "front_left_elbow", "back_left_hip", "back_left_knee", "neck",
                       "tail_base"]}
CLIPS = ["delfem2_walk.bvh", "assimp_Boxing_Toes.bvh", "assimp_01_01.bvh"]
PIECE_SIZE = 0.1     # pieces no larger than this fraction of the height are checked for far bones
TILT_LIMIT = 10.0    # degrees: frames where the clip's own head tilts less than this


def load_score(shared: Path):
    spec = importlib.util.spec_from_file_location("gt_score", shared / "tools" / "score.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def characters(shared: Path, corpus: Path | None, per_source: int, only: list[str]):
    """[(source, directory)] of the ground-truth characters, ``per_source`` of each source."""
    found = [("shared", d) for d in sorted((shared / "data" / "rigged").iterdir())]
    folders = [shared / "data" / "train"] + ([corpus] if corpus and corpus.is_dir() else [])
    for folder in folders:
        found += [(d.name.split("_")[0].split("-")[0], d) for d in sorted(folder.iterdir())]
    found = [(s, d) for s, d in found if (d / "joints.json").is_file() and (d / "weights.npz").is_file()
             and any(k in (d / "joints.json").read_text() for k in ('"biped_map"', '"quadruped_map"'))]
    if only:
        return [(s, d) for s, d in found if d.name in only]
    out = []
    for source in dict.fromkeys(s for s, _ in found):        # spread over each source, in name order
        mine = [(s, d) for s, d in found if s == source]
        picks = np.unique(np.linspace(0, len(mine) - 1, min(per_source, len(mine))).round().astype(int))
        out += [mine[k] for k in picks]
    return out


def artist_rig(gt) -> Rig:
    """The ground truth as a ``Rig`` whose mapped joints carry their template names, rooted at its hips (or
    the template's root): joints above it (a MakeHuman "Root" on the ground) are dropped, their weights
    given to it, so that a clip's hips drive it as they drive autorig's rig."""
    key_of = {n: k for k, n in gt["map"].items() if n is not None}
    names = [key_of.get(n, f"artist:{n}") for n in gt["joint_names"]]
    parents = np.asarray(gt["joint_parents"])
    W = np.asarray(gt["W"], float)
    root_key = "hips" if gt["kind"] == "biped" else next(iter(gt["map"]))
    root = names.index(root_key) if root_key in names else int(np.flatnonzero(parents < 0)[0])
    above = set()
    p = parents[root]
    while p >= 0:
        above.add(int(p))
        p = parents[p]
    order = [root] + [j for j in range(len(names)) if j != root and j not in above]
    new = {j: k for k, j in enumerate(order)}
    new_parents = np.array([-1] + [new[parents[j]] if parents[j] in new else 0 for j in order[1:]])
    weights = W[:, order]
    weights[:, 0] += W[:, sorted(above)].sum(axis=1) if above else 0.0
    return Rig(names=[names[j] for j in order], parents=new_parents,
               joints=np.asarray(gt["joint_pos"], float)[order], weights=weights, vertices=gt["V"], faces=gt["F"],
               template="artist")


def axis_name(v) -> str:
    k = int(np.argmax(np.abs(v)))
    return ("-" if v[k] < 0 else "") + "xyz"[k]


def subtree(parents, j) -> np.ndarray:
    inside = np.zeros(len(parents), bool)
    inside[j] = True
    for c in range(len(parents)):
        if parents[c] >= 0 and inside[parents[c]]:
            inside[c] = True
    return inside


def rotation(axis, degrees) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    return Rotation.from_rotvec(np.radians(degrees) * np.asarray(axis, float)).as_matrix()


def bend(r: Rig, name: str, R: np.ndarray):
    """(rotations [J, 3, 3], positions [J, 3]) of ``r`` with joint ``name``'s subtree turned by R about it."""
    J = len(r.names)
    rotations, positions = np.tile(np.eye(3), (J, 1, 1)), np.array(r.joints, float)
    j = r.names.index(name)
    moved = subtree(np.asarray(r.parents), j)
    rotations[moved] = R
    positions[moved] = (positions[moved] - positions[j]) @ R.T + positions[j]
    return rotations, positions


def poses(gt, kind, rigs, motion_dir: Path, frames: int):
    """Yield (label, [posed vertices per rig]) for every bend and clip frame both rigs can take."""
    up, front, left = gt["up"], gt["front"], gt["left"]
    for name in BENDS[kind]:
        if not all(name in r.names for r in rigs):
            continue
        axis = front if name.endswith("shoulder") else left
        sign = -1.0 if name.startswith("left") and name.endswith("shoulder") else 1.0
        R = rotation(sign * axis, BEND_DEGREES)
        yield f"bend {name}", [skin(r, *bend(r, name, R)) for r in rigs]
    if kind != "biped":
        return
    for clip in CLIPS:
        path = motion_dir / clip
        if not path.is_file():
            continue
        motion = read_bvh(path)
        try:
            anim = retarget(rigs[0], motion, up=axis_name(up), front=axis_name(front))
        except Exception as e:           # a rig the clip cannot drive (no hips) is reported, not fatal
            print(f"    {clip}: not retargeted ({e})", file=sys.stderr)
            continue
        for t in np.linspace(0, len(motion.frames) - 1, frames).round().astype(int):
            yield f"{clip}@{t}", [skin(rigs[0], anim.rotations[t], anim.positions[t])] + [
                skin(r, *same_rotations(rigs[0], anim.rotations[t], anim.positions[t], r)) for r in rigs[1:]]


def same_rotations(source: Rig, rotations, positions, target: Rig):
    """(rotations [J, 3, 3], positions [J, 3]) of ``target`` posed with the world rotations ``rotations`` of
    ``source``'s joints of the same names (a joint ``source`` lacks turns with its parent), its root moved as
    ``source``'s: both rigs take the same motion, whatever their bones' rest directions."""
    parents = np.asarray(target.parents)
    rest = np.asarray(target.joints, float)
    index = {n: i for i, n in enumerate(source.names)}
    root = int(np.flatnonzero(parents < 0)[0])
    source_root = int(np.flatnonzero(np.asarray(source.parents) < 0)[0])
    R = np.empty((len(parents), 3, 3))
    P = np.empty((len(parents), 3))
    for j, name in enumerate(target.names):
        p = parents[j]
        R[j] = rotations[index[name]] if name in index else (R[p] if p >= 0 else np.eye(3))
        P[j] = (rest[j] + positions[source_root] - np.asarray(source.joints, float)[source_root] if p < 0
                else P[p] + R[p] @ (rest[j] - rest[p]))
    return R, P


def pieces(V, F):
    """(labels [V] of the connected parts, after welding by position, body = the part of most vertices)."""
    _, first, weld = np.unique(np.round(V, 9), axis=0, return_index=True, return_inverse=True)
    weld = weld.reshape(-1)
    Fw = weld[F]
    n = len(first)
    adj = sp.coo_matrix((np.ones(Fw.size), (Fw.ravel(), np.roll(Fw, 1, axis=1).ravel())), shape=(n, n))
    _, label = connected_components(adj, directed=False)
    label = label[weld]
    body = int(np.argmax(np.bincount(label)))
    return label, body


def far_pieces(r: Rig, height: float, label, body) -> tuple[int, int]:
    """(pieces no larger than PIECE_SIZE of the height, of them those on a far joint; see the module doc)."""
    from autorig.weights.attach import segment_distances
    V, W, parents = np.asarray(r.vertices, float), np.asarray(r.weights, float), np.asarray(r.parents)
    P = np.asarray(r.joints, float)
    bones = np.flatnonzero(parents >= 0)
    heats = W.sum(axis=0) > 0
    bones = bones[heats[parents[bones]]]           # bones whose owner carries weight somewhere
    small = far = 0
    for piece in np.unique(label):
        idx = np.flatnonzero(label == piece)
        if piece == body or np.linalg.norm(np.ptp(V[idx], axis=0)) > PIECE_SIZE * height:
            continue
        small += 1
        dominant = int(np.argmax(W[idx].sum(axis=0)))
        centre = V[idx].mean(axis=0, keepdims=True)
        under = int(parents[bones[np.argmin(segment_distances(centre, P[parents[bones]], P[bones])[0])]])
        near = {under, int(parents[under])} | set(np.flatnonzero(parents == under).tolist())
        far += dominant not in near
    return small, far


def volume(V, F) -> float:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def score_character(score, source, gt_dir: Path, motion_dir: Path, frames: int):
    gt = score.load_gt(str(gt_dir))
    if gt["kind"] is None or gt["up"] is None or gt["front"] is None:
        return None
    start = time.perf_counter()
    ours = rig((gt["V"], gt["F"]), gt["kind"], RigOptions(up=axis_name(gt["up"]), front=axis_name(gt["front"])))
    seconds = time.perf_counter() - start
    artist = artist_rig(gt)
    H = gt["height"]
    F = np.asarray(gt["F"])
    rest_edges = np.linalg.norm(gt["V"][F] - gt["V"][np.roll(F, 1, axis=1)], axis=2)
    rest_volume = abs(volume(gt["V"], F)) or 1.0
    errors, tear, vol = {"bend": [], "clip": []}, [0.0, 0.0], [0.0, 0.0]
    for label, (posed_artist, posed_ours) in poses(gt, gt["kind"], [artist, ours], motion_dir, frames):
        errors["bend" if label.startswith("bend") else "clip"].append(
            np.linalg.norm(posed_artist - posed_ours, axis=1) / H)
        for k, posed in enumerate((posed_artist, posed_ours)):
            edges = np.linalg.norm(posed[F] - posed[np.roll(F, 1, axis=1)], axis=2)
            tear[k] = max(tear[k], float((edges - rest_edges).max() / H))
            if label.startswith("bend") and ("elbow" in label or "knee" in label):
                vol[k] = max(vol[k], (rest_volume - abs(volume(posed, F))) / rest_volume)
    label, body = pieces(gt["V"], F)
    stats = {}
    for kind, errs in errors.items():
        err = np.concatenate(errs) if errs else np.full(1, np.nan)
        stats[kind] = (100 * err.mean(), 100 * np.percentile(err, 95), 100 * err.max())
    return {"source": source, "name": gt_dir.name, "poses": sum(map(len, errors.values())), **stats,
            "seconds": seconds,
            "far": [far_pieces(r, H, label, body) for r in (artist, ours)],
            "tear": [100 * t for t in tear], "vol": [100 * v for v in vol]}


def head_tilt(mesh, motion_path: Path, template="biped", up="auto", front="auto"):
    """(worst head tilt of autorig's rig over the frames where the clip's head tilts less than TILT_LIMIT, the
    worst excess of its tilt over the clip's in any frame (degrees), those frames, all frames) of ``mesh``
    walking. A head's tilt is the angle between its bone's posed and rest directions (head -> head_end; the
    clip's: Head -> its end site, in the clip's world rotations)."""
    r = rig(mesh, template, RigOptions(up=up, front=front))
    motion = read_bvh(motion_path)
    anim = retarget(r, motion)
    head = r.names.index("head")
    d = r.joint("head_end") - r.joint("head")
    d = d / np.linalg.norm(d)
    ours = np.degrees(np.arccos(np.clip(anim.rotations[:, head] @ d @ d, -1, 1)))
    b = motion.names.index(anim.mapping["head"])
    kids = motion.children(b)
    m = np.asarray(motion.end_sites[b] if b in motion.end_sites else motion.offsets[kids[0]], float)
    m = m / np.linalg.norm(m)
    world_r, _ = motion.world_transforms()
    clip = np.degrees(np.arccos(np.clip(world_r[:, b] @ m @ m, -1, 1)))
    calm = clip < TILT_LIMIT
    return (float(ours[calm].max()) if calm.any() else float("nan")), float((ours - clip).max()), \
        int(calm.sum()), len(calm)


def tilt_table(shared: Path):
    from autorig.samples import mannequin
    walk = shared / "data" / "motion" / "delfem2_walk.bvh"
    sample = mannequin("t")
    cases = [("homer", shared / "data" / "meshes" / "homer.obj", {}),
             ("ogre", shared / "data" / "meshes" / "ogre.obj", {}),
             ("CesiumMan", shared / "data" / "rigged" / "CesiumMan" / "mesh.obj", {"front": "x", "up": "y"}),
             ("mannequin", (sample.vertices, sample.faces), {"up": "y", "front": "z"})]
    print(f"\nhead tilt walking (delfem2_walk.bvh): worst over the frames where the clip's head is within "
          f"{TILT_LIMIT:.0f} deg")
    for name, mesh, axes in cases:
        worst, excess, calm, total = head_tilt(mesh, walk, **axes)
        print(f"  {name:<12}{worst:>7.2f} deg   ({calm}/{total} frames); worst excess over the clip's tilt "
              f"{excess:.2f} deg")


def piece_drift(r: Rig, frames, label, body) -> np.ndarray:
    """[P] for each piece (connected part other than the body) the worst distance, over the posed ``frames``
    [(rotations, positions)], of its vertices from where its body part carries them: the rest piece moved by
    the rigid motion that best fits the closest body points of its vertices (posed through the rig's weights).
    A larger piece spans bones and bends with them, so only small pieces are held to this."""
    V, F = np.asarray(r.vertices, float), np.asarray(r.faces)
    others = [p for p in np.unique(label) if p != body]
    if not others:
        return np.zeros(0)
    idx = np.flatnonzero(label != body)
    _, corners, bary = closest_points(V, F, label == body, V[idx])
    contact = np.einsum("nk,nkj->nj", bary, V[corners])
    worst = np.zeros(len(others))
    for rotations, positions in frames:
        posed = skin(r, rotations, positions)
        carried = np.einsum("nk,nkj->nj", bary, posed[corners])
        for k, p in enumerate(others):
            m = label[idx] == p
            A, B = contact[m], carried[m]
            ca, cb = A.mean(axis=0), B.mean(axis=0)
            U, _, Vt = np.linalg.svd((A - ca).T @ (B - cb))
            D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
            R = (U @ D @ Vt).T
            expected = (V[idx[m]] - ca) @ R.T + cb
            worst[k] = max(worst[k], float(np.linalg.norm(posed[idx[m]] - expected, axis=1).max()))
    return worst


def closest_points(V, F, keep, X):
    """(distance [N], corners [N, 3], barycentric coordinates [N, 3]) of the closest points to X [N, 3] on the
    faces of V, F whose corners are all ``keep`` [V] (here, not autorig's, so that the benchmark measures any
    version of autorig alike)."""
    import igl
    faces = F[keep[F].all(axis=1)]
    d2, face, closest = igl.point_mesh_squared_distance(np.ascontiguousarray(X), V, faces)
    corners = faces[np.asarray(face, dtype=np.int64)]
    bary = igl.barycentric_coordinates(closest, V[corners[:, 0]], V[corners[:, 1]], V[corners[:, 2]])
    bary = np.clip(np.nan_to_num(bary, nan=1.0 / 3.0), 0.0, None)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), 1e-300)
    return np.sqrt(np.maximum(d2, 0.0)), corners, bary


def piece_table(shared: Path, frames: int):
    """The shared meshes with pieces: pieces on far bones, and how far pieces drift from their body part in
    the boxing and walk clips (% of the height)."""
    clips = [read_bvh(shared / "data" / "motion" / c) for c in ("assimp_Boxing_Toes.bvh", "delfem2_walk.bvh")]
    print(f"\npieces (shared meshes): far = pieces <= {PIECE_SIZE:.0%} of the height on a far joint; drift = worst "
          f"distance of a piece from where its body part carries it, {frames} frames of boxing and walk, % height")
    for name, options in (("ogre", {}), ("ogre", {"fingers": True}), ("beast", {})):
        r = rig(shared / "data" / "meshes" / f"{name}.obj", "biped", RigOptions(**options))
        V = np.asarray(r.vertices, float)
        from autorig.input.mesh import frame_rotation
        up = frame_rotation(r.info["up"], r.info["front"])[1]
        H = float(np.ptp(V @ up))
        label, body = pieces(V, np.asarray(r.faces))
        small, far = far_pieces(r, H, label, body)
        posed = []
        for motion in clips:
            anim = retarget(r, motion)
            posed += [(anim.rotations[t], anim.positions[t])
                      for t in np.linspace(0, len(motion.frames) - 1, frames).round().astype(int)]
        drift = 100 * piece_drift(r, posed, label, body) / H
        sizes = np.array([np.linalg.norm(np.ptp(V[label == p], axis=0)) / H for p in np.unique(label) if p != body])
        tag = name + (" --fingers" if options else "")
        line = f"  {tag:<16} pieces {len(drift):>3}  small {small:>3}  far {far:>3}"
        for what, sel in (("small", sizes <= PIECE_SIZE),):
            line += (f"  drift {what}: worst {drift[sel].max():5.2f}%, over 1%: {int((drift[sel] > 1).sum())}"
                     if sel.any() else "")
        print(line)


def _triple(t) -> str:
    return "/".join(f"{x:.2f}" for x in t) if np.isfinite(t[0]) else "-"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    ap.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    ap.add_argument("--per-source", type=int, default=3, help="characters per source (default 3)")
    ap.add_argument("--frames", type=int, default=6, help="frames of each clip (default 6)")
    ap.add_argument("--only", nargs="*", default=[], help="only these characters (folder names)")
    ap.add_argument("--no-tilt", action="store_true", help="skip the walking head-tilt table")
    ap.add_argument("--no-pieces", action="store_true", help="skip the shared meshes' pieces table")
    a = ap.parse_args(argv)
    score = load_score(a.shared)
    rows = []
    print("posed vertices, artist's rig against autorig's, % of the height: mean/p95/worst over the bends, "
          "then over the clips' frames")
    print(f"{'source':<8}{'character':<28}{'poses':>6}{'bends mean/p95/worst':>22}{'clips mean/p95/worst':>22}  "
          f"{'far art/ours':>13}{'tear% art/ours':>15}{'vol% art/ours':>14}")
    for source, d in characters(a.shared, a.corpus, a.per_source, a.only):
        try:
            row = score_character(score, source, d, a.shared / "data" / "motion", a.frames)
        except Exception as e:            # one character that fails to rig is reported, the rest go on
            print(f"{source:<11}{d.name:<34} failed: {type(e).__name__}: {e}")
            continue
        if row is None:
            continue
        rows.append(row)
        far = "/".join(f"{f}" for _, f in row["far"]) + f" of {row['far'][0][0]}"
        print(f"{source:<8}{row['name'][:27]:<28}{row['poses']:>6}{_triple(row['bend']):>22}"
              f"{_triple(row['clip']):>22}  {far:>13}{row['tear'][0]:>8.1f}/{row['tear'][1]:<6.1f}"
              f"{row['vol'][0]:>7.1f}/{row['vol'][1]:<6.1f}", flush=True)
    print("\nper source: mean of the means / mean of the 95th percentiles / worst (% of the height); far pieces")
    for source in dict.fromkeys(r["source"] for r in rows):
        sel = [r for r in rows if r["source"] == source]
        far = [sum(r["far"][k][1] for r in sel) for k in (0, 1)]
        summary = {kind: (np.nanmean([r[kind][0] for r in sel]), np.nanmean([r[kind][1] for r in sel]),
                          np.nanmax([r[kind][2] for r in sel])) if any(np.isfinite(r[kind][0]) for r in sel)
                   else (np.nan,) * 3 for kind in ("bend", "clip")}
        print(f"  {source:<10}{len(sel):>3} chars  bends {_triple(summary['bend'])}  clips {_triple(summary['clip'])}"
              f"  far pieces artist {far[0]} ours {far[1]} of {sum(r['far'][0][0] for r in sel)}")
    if not a.no_pieces:
        piece_table(a.shared, a.frames)
    if not a.no_tilt:
        tilt_table(a.shared)
    return 0


if __name__ == "__main__":
    sys.exit(main())
