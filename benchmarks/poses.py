"""Bipeds in poses other than T, A and arms down: arms bent in front of the chest, a stride, seated, idle stance.

    python benchmarks/poses.py [--shared ../shared] [--corpus ../corpus] [--all] [--humanoid] [--folds K]
                               [--out DIR] [--json FILE] [--poses NAME,...]

Each character (by default 8 MakeHuman bodies from ``--corpus`` and 8 0 A.D. bipeds from ``shared/data/train``;
``--all`` for every biped example the shipped biped learns from) is re-posed through its artist's weights as
``humanoid.py`` re-poses arms: the artist's joints' frames are turned (forward kinematics down the artist's
hierarchy) and the mesh is skinned with the artist's weights (linear blend skinning). A pose is a list of bones
(a joint of the ``biped_map`` and the one its bone points to) with the direction each bone is turned to, in the
body's frame (left, up, front from the character's joints.json); a bone not listed keeps its rest direction
relative to its parent, except feet, which are kept flat. The poses:

- ``arms bent``: upper arms 40 deg forward of hanging down (10 deg outward), elbows bent 90 deg so that the
  forearms point inward and a little up in front of the chest (as holding a weapon);
- ``stride``: left thigh 25 deg forward, right thigh 15 deg back, knees bent 20 and 15 deg, feet flat;
- ``seated``: thighs 85 deg forward, knees bent 90 deg (shins down), feet flat;
- ``idle``: arms bent and stride together;

and, only when ``--poses`` names them (issue 37 asks for the four above):

- ``hands on hips``: upper arms 45 deg out of hanging down, forearms inward and down onto the hips (akimbo);
- ``arm raised``: the left arm raised above the head, the right as at rest;
- ``reach``: both arms straight forward, level.

Every posed character is rigged with the shipped biped (and with ``--humanoid`` the shipped humanoid; they
learned from these characters, in their rest poses only), or with ``--folds K`` with templates learned as
``humanoid.py`` learns them from the folds of whole groups that do not hold the character; always with its axes
given and in its source's own convention. Scored: for each wrist, ankle and the head, whether the rig's joint
is nearer its own artist's joint than any other of those five and within 15 % of the height (structure right);
and the anatomy joints (elbows, wrists, knees, ankles, head) mean and worst error, % of the height (the rest
pose's height along up), with how many of the rigs whose structure is wrong score a confidence below 0.5 and
how many of the right ones 0.5 or more (a pipeline trusts what scores 0.5 or more). As a sanity check of each posed
mesh, ``spread`` (how far its vertices moved from the rest, mean, % of the height) is printed, and how far apart
the artist's wrists are in it (% of the height: the nearer, the finer the structure test on them); ``--out`` keeps
the posed characters (mesh.obj, joints.json, weights.npz) to look at with ``autorig preview``.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from humanoid import AXES, read_obj_vertices  # noqa: E402

ENDS = ("left_wrist", "right_wrist", "left_ankle", "right_ankle", "head")
ANATOMY = ("left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_knee", "right_knee",
           "left_ankle", "right_ankle", "head")


def _sag(angle_forward: float, out: float = 0.0) -> tuple[float, float, float]:
    """A downward direction turned ``angle_forward`` deg toward the front and ``out`` deg outward (the sign of
    'left' is flipped per side by ``POSES``' user)."""
    a, o = np.radians(angle_forward), np.radians(out)
    return (float(np.sin(o)), float(-np.cos(a) * np.cos(o)), float(np.sin(a) * np.cos(o)))


def _forearm() -> tuple[float, float, float]:
    """Perpendicular to the upper arm of ``_sag(40, 10)``: inward (medial, negative "out"), 45 deg off the
    frontal-plane, tilted forward and up with the upper arm's swing."""
    upper = np.array(_sag(40, 10))
    w = np.array([0.0, np.sin(np.radians(40)), np.cos(np.radians(40))])   # forward-up, perpendicular-ish
    medial = np.array([-1.0, 0.0, 0.0])
    f = np.cos(np.radians(45)) * medial + np.sin(np.radians(45)) * w
    f -= (f @ upper) * upper                                                 # exactly 90 deg at the elbow
    return tuple(float(x) for x in f / np.linalg.norm(f))


# pose -> [(side-relative bone (from, to) of the biped_map, direction (outward, up, front))]; "L/R" both sides.
ARMS = [(("shoulder", "elbow"), _sag(40, 10)), (("elbow", "wrist"), _forearm())]
STRIDE = {"left": [(("hip", "knee"), _sag(25)), (("knee", "ankle"), _sag(5))],
          "right": [(("hip", "knee"), _sag(-15)), (("knee", "ankle"), _sag(-30))]}
SEATED = [(("hip", "knee"), _sag(85)), (("knee", "ankle"), _sag(-5))]
POSES = {
    "arms bent": {"left": ARMS, "right": ARMS},
    "stride": STRIDE,
    "seated": {"left": SEATED, "right": SEATED},
    "idle": {s: ARMS + STRIDE[s] for s in ("left", "right")},
}
DEFAULT_POSES = tuple(POSES)     # what a run without --poses measures (issue 37's poses)


def _unit(*v: float) -> tuple[float, float, float]:
    v = np.array(v, float) / np.linalg.norm(v)
    return (float(v[0]), float(v[1]), float(v[2]))


# Poses the default run leaves out (``--poses`` takes them): hands on the hips (akimbo: upper arms 45 deg out
# of hanging down, forearms inward and down onto the hips, the hands touching or pressed into the body), the
# left arm raised above the head (a little out and forward, the right as at rest), both arms reaching forward.
AKIMBO = [(("shoulder", "elbow"), _unit(0.7, -0.7, -0.1)), (("elbow", "wrist"), _unit(-0.55, -0.8, 0.15))]
RAISED = [(("shoulder", "elbow"), _unit(0.15, 0.95, 0.3)), (("elbow", "wrist"), _unit(0.05, 0.95, 0.3))]
REACH = [(("shoulder", "elbow"), _unit(0.05, 0.0, 1.0)), (("elbow", "wrist"), _unit(0.0, 0.0, 1.0))]
POSES.update({
    "hands on hips": {"left": AKIMBO, "right": AKIMBO},
    "arm raised": {"left": RAISED, "right": []},
    "reach": {"left": REACH, "right": REACH},
})


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking direction ``a`` to direction ``b``."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    v, c = np.cross(a, b), float(a @ b)
    if c < -1 + 1e-9:                       # opposite: turn 180 deg about any perpendicular
        p = np.cross(a, [1.0, 0, 0]) if abs(a[0]) < 0.9 else np.cross(a, [0, 1.0, 0])
        p /= np.linalg.norm(p)
        return 2 * np.outer(p, p) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def pose_character(meta: dict, vertices: np.ndarray, weights: np.ndarray, pose: str
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(posed vertices [V, 3], posed joint positions [J, 3]) of a character (its joints.json ``meta``, rest
    ``vertices`` and artist's ``weights`` [V, J]) in ``pose`` (a key of ``POSES``)."""
    joints = meta["joints"]
    names = [j["name"] for j in joints]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[j["parent"]] if j["parent"] is not None else -1 for j in joints]
    rest = np.array([j["position"] for j in joints], float)
    up = np.array(AXES[meta.get("up_axis", "+y")], float)
    front = np.array(AXES[meta.get("front_axis", "+z")], float)
    left = np.cross(up, front)
    bmap = meta["biped_map"]
    targets = {}       # joint index -> (child joint index, target world direction)
    for side, bones in POSES[pose].items():
        outward = left if side == "left" else -left
        for (a, b), (o, u, f) in bones:
            ja, jb = bmap.get(f"{side}_{a}"), bmap.get(f"{side}_{b}")
            if ja is None or jb is None:
                raise ValueError(f"{meta.get('name')}: no {side}_{a} or {side}_{b} in its biped_map")
            targets[index[ja]] = (index[jb], o * outward + u * up + f * front)
    flat = {index[bmap[f"{s}_ankle"]] for s in ("left", "right") if bmap.get(f"{s}_ankle")}

    def turn(k: int, inherited: np.ndarray) -> np.ndarray:
        if k in targets:
            child, direction = targets[k]
            return _rotation_between(inherited @ (rest[child] - rest[k]), direction) @ inherited
        if k in flat:
            return np.eye(3)            # the foot keeps its rest orientation: flat on the ground
        return inherited
    world, posed = posed_skeleton(parents, rest, turn)
    return skinned(vertices, weights, world, rest, posed), posed


def posed_skeleton(parents, rest: np.ndarray, turn) -> tuple[np.ndarray, np.ndarray]:
    """(world [J, 3, 3], posed [J, 3]): forward kinematics down the hierarchy ``parents`` [J] from the ``rest``
    joints [J, 3], each joint's frame turn (world axes, rest -> posed) ``turn(k, its parent's turn)``."""
    order = sorted(range(len(parents)), key=lambda k: _depth(parents, k))
    world = np.tile(np.eye(3), (len(parents), 1, 1))
    posed = rest.copy()
    for k in order:
        p = parents[k]
        inherited = world[p] if p >= 0 else np.eye(3)
        if p >= 0:
            posed[k] = posed[p] + inherited @ (rest[k] - rest[p])
        world[k] = turn(k, inherited)
    return world, posed


def skinned(vertices: np.ndarray, weights: np.ndarray, world: np.ndarray, rest: np.ndarray,
            posed: np.ndarray) -> np.ndarray:
    """[V, 3] the rest ``vertices`` skinned by linear blending (``weights`` [V, J]) to the joints turned by
    ``world`` [J, 3, 3] from ``rest`` [J, 3] to ``posed`` [J, 3]."""
    moved = np.einsum("jab,vjb->vja", world, vertices[:, None, :] - rest[None]) + posed[None]
    return np.einsum("vj,vja->va", weights, moved)


def _depth(parents, k: int) -> int:
    d = 0
    while parents[k] >= 0:
        k, d = parents[k], d + 1
    return d


def write_posed(folder: Path, pose: str, out: Path) -> Path:
    """A copy of the character ``folder`` posed as ``pose`` in ``out`` (mesh.obj, joints.json, weights.npz)."""
    meta = json.loads((folder / "joints.json").read_text())
    vertices, lines = read_obj_vertices(folder / "mesh.obj")
    with np.load(folder / "weights.npz") as npz:
        weights = np.asarray(npz["weights"], float)
    new_vertices, new_positions = pose_character(meta, vertices, weights, pose)
    out.mkdir(parents=True, exist_ok=True)
    k = iter(new_vertices)
    (out / "mesh.obj").write_text("\n".join(
        ("v " + " ".join(f"{x:.6f}" for x in next(k))) if line.startswith("v ") else line for line in lines) + "\n")
    meta["joints"] = [{**j, "position": [float(v) for v in p]} for j, p in zip(meta["joints"], new_positions)]
    meta["rest_pose"] = f"re-posed by benchmarks/poses.py: {pose}"
    (out / "joints.json").write_text(json.dumps(meta))
    shutil.copy(folder / "weights.npz", out / "weights.npz")
    return out


def score_ends(meta: dict, rig_names: list[str], rig_joints: np.ndarray) -> dict:
    """{"structure": all five ends right, "wrong": [ends that are not: "left_wrist at right_wrist" when nearer
    another end's truth, the name alone when only too far], "errors": {anatomy joint: % of height}}."""
    height = float(meta["height_along_up"])
    at = {j["name"]: np.array(j["position"], float) for j in meta["joints"]}
    truth = {k: at[meta["biped_map"][k]] for k in ANATOMY if meta["biped_map"].get(k)}
    mine = dict(zip(rig_names, np.asarray(rig_joints, float)))
    errors = {k: 100 * float(np.linalg.norm(mine[k] - truth[k])) / height for k in ANATOMY
              if k in mine and k in truth}
    wrong = []
    for k in ENDS:
        if k not in mine or k not in truth:
            wrong.append(k)
            continue
        d = {o: float(np.linalg.norm(mine[k] - truth[o])) for o in ENDS if o in truth}
        nearest = min(d, key=d.get)
        if nearest != k:
            wrong.append(f"{k} at {nearest}")
        elif d[k] > 0.15 * height:
            wrong.append(k)
    return {"structure": not wrong, "wrong": wrong, "errors": errors}


def characters(shared: Path, corpus: Path, every: bool) -> list[Path]:
    """8 MakeHuman bodies (Unreal-style rig, one per body) and 8 0 A.D. bipeds, or with ``every`` all the
    biped examples the shipped biped learns from."""
    from sources import examples
    record = json.loads((ROOT / "templates" / "biped.json").read_text())["learned_from"]
    items = [(f, s) for f, s, _ in examples(shared, corpus) if s in record["sources"]]
    if every:
        return [f for f, _ in items]
    human = [f for f, s in items if s == "makehuman-ue"][:8]
    zero = [f for f, s in items if s == "0ad"][:8]
    return human + zero


def templates_for(folders: list[Path], kinds: list[str], shared: Path, corpus: Path, folds: int, out_dir: Path,
                  say) -> dict[tuple[str, Path], Path | str]:
    """{(kind, folder): template}: the shipped template's name, or with ``folds`` > 0 a template learned as
    ``humanoid.py`` learns it (``templates/retrain.sh``'s record) from the folds of whole groups that do not
    hold ``folder`` (its body's group never seen)."""
    if folds <= 0:
        return {(kind, f): kind for kind in kinds for f in folders}
    from humanoid import folds_of
    from sources import examples

    from autorig.exchange import write_file_atomic
    from autorig.learn import learn_template
    from autorig.template import load_template
    record = json.loads((ROOT / "templates" / "biped.json").read_text())["learned_from"]
    items = [item for item in examples(shared, corpus) if item[1] in record["sources"]]
    wanted = {f.resolve() for f in folders}
    out = {}
    for k, (train, test) in enumerate(folds_of(items, folds)):
        mine = [f for f in test if f.resolve() in wanted]
        if not mine:
            continue
        for kind in kinds:
            rec = json.loads((ROOT / "templates" / f"{kind}.json").read_text())["learned_from"]
            base = load_template(ROOT / "templates" / "handset" / f"{kind}.json")
            learned = learn_template(train, base=base, name=kind, parts=rec["learned"],
                                     conventions=rec.get("conventions"),
                                     default=rec.get("default_convention")).template
            path = out_dir / f"{kind}_fold{k}.json"
            write_file_atomic(path, json.dumps(learned.to_dict()).encode())
            say(f"fold {k + 1}/{folds} {kind}: learned from {len(train)}, for {len(mine)} held out")
            for f in mine:
                out[(kind, f.resolve())] = path
    return {(kind, f): out[(kind, f.resolve())] for kind in kinds for f in folders}


def evaluate(folders: list[Path], poses: list[str], kinds: list[str], out_dir: Path, say,
             templates: dict | None = None) -> list[dict]:
    from types import SimpleNamespace

    import autorig
    from autorig.learn.conventions import convention_for_source, source_of
    from autorig.template import load_template
    templates = templates or {(kind, f): kind for kind in kinds for f in folders}
    rows = []
    for folder in folders:
        meta0 = json.loads((folder / "joints.json").read_text())
        height = float(meta0["height_along_up"])
        up, front = (meta0.get(k, d).lstrip("+") for k, d in (("up_axis", "+y"), ("front_axis", "+z")))
        source = source_of(SimpleNamespace(name=folder.name, meta=meta0), folder)
        for pose in poses:
            try:
                posed = write_posed(folder, pose, out_dir / f"{folder.name}_{pose.replace(' ', '_')}")
            except Exception as e:
                rows.append({"model": folder.name, "pose": pose, "kind": "-", "error": f"{type(e).__name__}: {e}"})
                say(line(rows[-1]))
                continue
            meta = json.loads((posed / "joints.json").read_text())
            rest_v, _ = read_obj_vertices(folder / "mesh.obj")
            new_v, _ = read_obj_vertices(posed / "mesh.obj")
            spread = 100 * float(np.linalg.norm(new_v - rest_v, axis=1).mean()) / height
            at = {j["name"]: np.array(j["position"]) for j in meta["joints"]}
            bmap = meta["biped_map"]
            gap = 100 * float(np.linalg.norm(at[bmap["left_wrist"]] - at[bmap["right_wrist"]])) / height
            for kind in kinds:
                row = {"model": folder.name, "pose": pose, "kind": kind, "spread": spread, "wrist_gap": gap}
                try:
                    template = templates[(kind, folder)]
                    conventions = load_template(template).conventions or {}
                    convention = convention_for_source(conventions, source)   # the source's own habit
                    rig = autorig.rig(posed / "mesh.obj", template,
                                      autorig.RigOptions(up=up, front=front, convention=convention))
                    row.update(score_ends(meta, list(rig.names), rig.joints),
                               confidence=rig.info.get("confidence"))
                except Exception as e:       # a rig that fails is a result too
                    row["error"] = f"{type(e).__name__}: {e}"
                rows.append(row)
                say(line(row))
    return rows


def line(row: dict) -> str:
    head = f"  {row['kind']:8s} {row['model'][:44]:44s} {row['pose']:9s}"
    if "error" in row:
        return f"{head} failed: {row['error']}"
    e = row["errors"]
    conf = row.get("confidence")
    return (f"{head} spread {row['spread']:4.1f} wrists {row['wrist_gap']:4.1f} apart  structure "
            f"{'right' if row['structure'] else 'WRONG'}"
            f"{'' if row['structure'] else ' (' + ','.join(row['wrong']) + ')'}  anatomy mean "
            f"{np.mean(list(e.values())):4.1f} worst {max(e.values()):5.1f} ({max(e, key=e.get)})"
            + (f"  confidence {conf:.2f}" if isinstance(conf, (int, float)) else ""))


def summary(rows: list[dict]) -> str:
    out = ["\nper pose: structure right (each wrist, ankle, head nearest its own and within 15 %), anatomy joints "
           "(elbows, wrists, knees, ankles, head) % of height:"]
    for kind in sorted({r["kind"] for r in rows if r["kind"] != "-"}):
        every = []
        for pose in dict.fromkeys(r["pose"] for r in rows):
            mine = [r for r in rows if r["kind"] in (kind, "-") and r["pose"] == pose]
            ok = [r for r in mine if "error" not in r]
            every += mine
            out.append(_stats(f"  {kind:8s} {pose:9s}", mine, ok))
        out.append(_stats(f"  {kind:8s} {'all':9s}", every, [r for r in every if "error" not in r]))
    return "\n".join(out)


def _stats(head: str, mine: list[dict], ok: list[dict]) -> str:
    if not ok:
        return f"{head} {len(mine)} rigs, all failed"
    errors = [v for r in ok for v in r["errors"].values()]
    low = [r["confidence"] for r in ok if not r["structure"] and isinstance(r.get("confidence"), (int, float))]
    high = [r["confidence"] for r in ok if r["structure"] and isinstance(r.get("confidence"), (int, float))]
    return (f"{head} structure right {sum(r['structure'] for r in ok)}/{len(mine)}  anatomy mean "
            f"{np.mean(errors):4.1f} worst {max(errors):5.1f}  failed {len(mine) - len(ok)}"
            f"  wrong ones with confidence < 0.5: {sum(c < 0.5 for c in low)}/{len(low)}"
            f"  right ones with confidence >= 0.5: {sum(c >= 0.5 for c in high)}/{len(high)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--all", action="store_true", help="every biped example, not 8 + 8")
    parser.add_argument("--humanoid", action="store_true", help="also the shipped humanoid")
    parser.add_argument("--poses", default=",".join(DEFAULT_POSES),
                        help="comma-separated, of: " + ", ".join(POSES) + f" (default: {', '.join(DEFAULT_POSES)})")
    parser.add_argument("--folds", type=int, default=0,
                        help="cross-validate: learn each template without the character's group (0: the shipped)")
    parser.add_argument("--out", type=Path, help="keep the posed characters here (OBJ for autorig preview)")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    args = parser.parse_args(argv)
    poses = [p.strip() for p in args.poses.split(",") if p.strip()]
    unknown = [p for p in poses if p not in POSES]
    if unknown:
        print(f"error: unknown pose {unknown[0]!r}; known: {', '.join(POSES)}", file=sys.stderr)
        return 2
    kinds = ["biped", "humanoid"] if args.humanoid else ["biped"]
    folders = characters(args.shared, args.corpus, args.all)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        templates = templates_for(folders, kinds, args.shared, args.corpus, args.folds, out_dir, print)
        rows = evaluate(folders, poses, kinds, out_dir, print, templates)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    print(summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
