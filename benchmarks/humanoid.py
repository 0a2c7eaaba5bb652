"""The humanoid template cross-validated by group, in T-pose, A-pose and with the arms down.

    python benchmarks/humanoid.py [--shared ../shared] [--corpus ../corpus] [--folds 4] [--out DIR] [--json FILE]
                                  [--biped]

The examples are the biped's (``benchmarks/sources.py``): 0 A.D.'s characters, the shared glTF samples and the
MakeHuman bodies under their Mixamo and Unreal-style rigs. They are split into ``--folds`` folds of whole groups
(0 A.D.'s characters sharing a body mesh together, one MakeHuman body under both rigs together); for each fold
the humanoid is learned from the others as ``templates/retrain.sh`` learns it (the shipped template's
``learned_from`` record says what) and every held-out character is rigged in its source's own convention.

Each held-out character is rigged three times, re-posed through its artist's weights (linear blend skinning of
its mesh with ``weights.npz``): both upper arms turned about their shoulder joints in the body's frontal plane
until the shoulder-to-wrist line is POSES degrees below the horizontal (T 0, A 40, arms down 70; 0 A.D.'s
characters are modelled at 67, MakeHuman's at 0 or 45). The re-posed ground truth is written beside the rigs
(never into the repository) and scored by ``shared/tools/score.py`` as the biped is (19 joints, the humanoid's
``spine2`` standing for the biped's chest; weight top-1), and the humanoid's own body joints (those 19 with
``spine1`` and the clavicles, as ``autorig.learn.humanoid_map`` reads them off each rig) by their distance to the
truth, % of the height. The rest pose each rig reports (``rig.info["rest_pose"]``) is checked against the pose.
With ``--biped`` the biped is learned and rigged on the same folds and poses for comparison.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
POSES = {"T": 0.0, "A": 40.0, "arms down": 70.0}
AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1),
        "x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
EXTRA = ("spine1", "left_clavicle", "right_clavicle")


def read_obj_vertices(path: Path) -> tuple[np.ndarray, list[str]]:
    """(vertices [V, 3], every line of the OBJ file) so that a re-posed copy keeps its faces and the rest."""
    lines = path.read_text().splitlines()
    return np.array([[float(v) for v in line.split()[1:4]] for line in lines if line.startswith("v ")]), lines


def repose(folder: Path, angle: float, out: Path) -> Path:
    """A copy of the corpus character ``folder`` in ``out`` with both arms turned (linear blend skinning with
    the artist's weights) until each shoulder-to-wrist line is ``angle`` degrees below the horizontal."""
    meta = json.loads((folder / "joints.json").read_text())
    joints = meta["joints"]
    names = [j["name"] for j in joints]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[j["parent"]] if j["parent"] is not None else -1 for j in joints]
    positions = np.array([j["position"] for j in joints], float)
    up = np.array(AXES[meta.get("up_axis", "+y")], float)
    front = np.array(AXES[meta.get("front_axis", "+z")], float)
    left = np.cross(up, front)
    vertices, lines = read_obj_vertices(folder / "mesh.obj")
    with np.load(folder / "weights.npz") as npz:
        weights = np.asarray(npz["weights"], float)
    rotations = np.tile(np.eye(3), (len(names), 1, 1))
    pivots = np.zeros((len(names), 3))
    bmap = meta["biped_map"]
    for side in ("left", "right"):
        shoulder, wrist = index[bmap[f"{side}_shoulder"]], index[bmap[f"{side}_wrist"]]
        arm = positions[wrist] - positions[shoulder]
        outward = float(arm @ left)
        now = np.degrees(np.arctan2(-(arm @ up), abs(outward)))
        turn = np.radians(angle - now) * (-1.0 if outward > 0 else 1.0)
        # Rotation about the front axis by ``turn`` (right-handed), in the file's own axes.
        basis = np.stack([left, up, front])
        c, s = np.cos(turn), np.sin(turn)
        rotation = basis.T @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ basis
        below = [shoulder]
        for k in range(len(names)):
            node = parents[k]
            while node >= 0 and node != shoulder:
                node = parents[node]
            if node == shoulder:
                below.append(k)
        rotations[below] = rotation
        pivots[below] = positions[shoulder]
    moved = np.einsum("jab,vjb->vja", rotations, vertices[:, None, :] - pivots[None]) + pivots[None]
    new_vertices = np.einsum("vj,vja->va", weights, moved)
    new_positions = np.einsum("jab,jb->ja", rotations, positions - pivots) + pivots
    out.mkdir(parents=True, exist_ok=True)
    k = iter(new_vertices)
    (out / "mesh.obj").write_text("\n".join(
        ("v " + " ".join(f"{x:.6f}" for x in next(k))) if line.startswith("v ") else line for line in lines) + "\n")
    meta["joints"] = [{**j, "position": [float(v) for v in p]} for j, p in zip(joints, new_positions)]
    meta["rest_pose"] = f"re-posed by benchmarks/humanoid.py: arms {angle:.0f} deg below the horizontal"
    (out / "joints.json").write_text(json.dumps(meta))
    shutil.copy(folder / "weights.npz", out / "weights.npz")
    return out


def folds_of(items, folds: int) -> list[tuple[list[Path], list[Path]]]:
    """[(training folders, test folders)] for ``folds`` folds of whole groups (sorted groups dealt in turn)."""
    groups = sorted({g for _, _, g in items})
    fold_of = {g: k % folds for k, g in enumerate(groups)}
    return [([f for f, _, g in items if fold_of[g] != k], [f for f, _, g in items if fold_of[g] == k])
            for k in range(folds)]


def body_errors(gt_folder: Path, glb: Path) -> dict[str, float]:
    """{humanoid joint: distance to its truth / height} for the humanoid joints the character's rig has."""
    from score import read_glb

    from autorig.learn.humanoid_map import with_humanoid_map
    meta = json.loads((gt_folder / "joints.json").read_text())
    joints = meta.pop("joints")
    truth = {j["name"]: np.array(j["position"], float) for j in joints}
    mapping = with_humanoid_map(meta, joints)["humanoid_map"]
    rig = read_glb(str(glb))
    at = dict(zip(rig["joint_names"], rig["joint_pos"]))
    return {k: float(np.linalg.norm(at[k] - truth[v]) / meta["height_along_up"])
            for k, v in mapping.items() if v is not None and k in at}


def evaluate(shared: Path, corpus: Path, folds: int, out_dir: Path, say, kinds=("humanoid",)) -> list[dict]:
    sys.path.insert(0, str(shared / "tools"))
    import score
    from sources import examples

    import autorig
    from autorig.exchange import write_file_atomic, write_rig
    from autorig.learn import learn_template
    from autorig.learn.conventions import convention_for_source, source_of
    from autorig.learn.examples import read_example
    from autorig.template import load_template

    record = json.loads((ROOT / "templates" / "humanoid.json").read_text())["learned_from"]
    # The sources the shipped templates learn from (Lugaru's rabbit and wolf are no human's proportions).
    items = [item for item in examples(shared, corpus) if item[1] in record["sources"]]
    source = {f: s for f, s, _ in items}
    rows = []
    for k, (train, test) in enumerate(folds_of(items, folds)):
        for kind in kinds:
            record = json.loads((ROOT / "templates" / f"{kind}.json").read_text())["learned_from"]
            base = load_template(ROOT / "templates" / "handset" / f"{kind}.json")
            start = time.perf_counter()
            learned = learn_template(train, base=base, name=kind,
                                     parts=record["learned"], conventions=record.get("conventions"),
                                     default=record.get("default_convention")).template
            path = out_dir / f"{kind}_{k}.json"
            write_file_atomic(path, json.dumps(learned.to_dict()).encode())
            say(f"fold {k + 1}/{folds} {kind}: learned from {len(train)} in {time.perf_counter() - start:.0f} s")
            for folder in test:
                example = read_example(folder, base)
                own = convention_for_source(learned.conventions or {}, source_of(example, folder))
                convention = own if own in (learned.conventions or {}) else learned.default_convention
                for pose, angle in POSES.items():
                    row = {"model": folder.name, "source": source[folder], "kind": kind, "pose": pose,
                           "fold": k}
                    try:
                        gt_folder = repose(folder, angle, out_dir / "poses" / f"{folder.name}_{pose.replace(' ', '_')}")
                        rig = autorig.rig(gt_folder / "mesh.obj", path,
                                          autorig.RigOptions(up=example.up, front=example.front,
                                                             convention=convention))
                        glb = out_dir / f"{kind}_{folder.name}_{pose.replace(' ', '_')}.glb"
                        write_rig(rig, glb, "glb")
                        gt = score.load_gt(str(gt_folder))
                        pred_map = {n: ("chest" if n == "spine2" else n) for n in rig.names
                                    if n in score.BIPED_PARENT or n == "spine2"}
                        result = score.score_glb(gt, str(glb), kind="biped", pred_map=pred_map)
                        errors = body_errors(gt_folder, glb) if kind == "humanoid" else {}
                        row.update(mean=100 * result["joints"]["mean"], max=100 * result["joints"]["max"],
                                   top1=result["weights"]["top1_pct"],
                                   body=100 * float(np.mean(list(errors.values()))) if errors else None,
                                   extra={j: 100 * errors[j] for j in EXTRA if j in errors},
                                   found=rig.info.get("rest_pose"), arm_angle=rig.info.get("arm_angle"),
                                   seconds=sum(rig.timings.values()))
                    except Exception as e:    # a rig that fails is a result too
                        row["error"] = f"{type(e).__name__}: {e}"
                    rows.append(row)
                    say(line(row))
    return rows


def line(row: dict) -> str:
    head = f"  {row['kind']:8s} {row['model'][:40]:40s} {row['pose']:9s}"
    if "error" in row:
        return f"{head} failed: {row['error']}"
    body = f" body {row['body']:4.1f}" if row["body"] is not None else ""
    return (f"{head} mean {row['mean']:4.1f} max {row['max']:5.1f}{body} top-1 {row['top1']:5.1f}  found "
            f"{row['found']} ({row['arm_angle']} deg)")


def summary(rows: list[dict]) -> str:
    out = ["\nmean joint error (% of height, the biped's 19 joints | the humanoid's body joints with spine1 and "
           "clavicles), weight top-1 %, rest pose found right:"]
    for kind in sorted({r["kind"] for r in rows}):
        for pose in POSES:
            mine = [r for r in rows if r["kind"] == kind and r["pose"] == pose]
            ok = [r for r in mine if "error" not in r]
            if not ok:
                continue
            by_source = defaultdict(list)
            for r in ok:
                by_source[r["source"]].append(r["mean"])
            bodies = [r["body"] for r in ok if r["body"] is not None]
            extra = {j: np.mean([r["extra"][j] for r in ok if j in r.get("extra", {})]) for j in EXTRA
                     if any(j in r.get("extra", {}) for r in ok)}
            out.append(
                f"  {kind:8s} {pose:9s} {len(ok):3d} rigs: mean {np.mean([r['mean'] for r in ok]):4.2f}"
                + (f" | body {np.mean(bodies):4.2f}" if bodies else "")
                + f"  worst joint {max(r['max'] for r in ok):5.1f}  top-1 {np.mean([r['top1'] for r in ok]):5.1f}"
                + f"  pose right {sum(r['found'] == pose for r in ok)}/{len(ok)}  failed "
                + f"{len(mine) - len(ok)}  | by source "
                + ", ".join(f"{s} {np.mean(v):.2f}" for s, v in sorted(by_source.items()))
                + ("  | " + ", ".join(f"{j} {v:.2f}" for j, v in extra.items()) if extra else ""))
    return "\n".join(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--out", type=Path, help="keep the templates, re-posed characters and rigs here")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    parser.add_argument("--biped", action="store_true", help="also the biped, on the same folds and poses")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        rows = evaluate(args.shared, args.corpus, args.folds, out_dir, print,
                        ("humanoid", "biped") if args.biped else ("humanoid",))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    print(summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
