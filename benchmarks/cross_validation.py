"""Cross-validated accuracy of learned templates on the training corpus: train on the others, test on unseen groups.

    python benchmarks/cross_validation.py [--shared ../shared] [--kinds biped,quadruped] [--folds 4] [--out DIR]

The corpus (``shared/data/train``) is split into groups that must never be on both sides: bipeds that share a
body mesh, quadrupeds that share a skeleton (a species or family: the bovids, the bears, the pigs). The groups
are dealt round-robin into folds; for each fold a template is learned with ``autorig.learn.learn_template`` from
the other folds, learning what the built-in template of the kind learned (``shipped_parts``: the biped its
proportions, penalty weights, placement and confidence; the quadruped its head/tail cue, placement and
confidence) unless ``--learn`` says otherwise, and every character of the fold is rigged with
it, with the axes given (+y up, +z front) and detected, and scored by ``shared/tools/score.py``. "Before" is
the hand-set template of the same kind (``templates/handset/``, the base the built-in ones are learned from).

Reported per kind: mean and worst joint error (% of the height), weight top-1 agreement, whether the detected
axes gave the same rig (every joint within 1 % of the height), whether they are found with the mesh turned to
face -z and turned Z-up (facing -y) as other tools write files, and the confidence against the true error
(rigs with their worst joint more than 20 % off should score below 0.5, those within 10 % at 0.5 or above).
Quadrupeds are also scored apart from their species' trunk convention (``benchmarks/quadruped_score.py``: limbs
as points, the artist's hips, spine, chest and neck by their distance from the rig's trunk line), per character
before and after (axes given) and summed up against issue 26's targets.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import quadruped_score

ROOT = Path(__file__).resolve().parents[1]
HANDSET = ROOT / "templates" / "handset"


def shipped_parts(kind: str) -> list[str]:
    """What the built-in template of ``kind`` learned (its ``learned_from`` record, written by
    ``templates/retrain.sh``), so that "after" measures the template users get."""
    return list(json.loads((ROOT / "templates" / f"{kind}.json").read_text())["learned_from"]["learned"])


def corpus(train: Path, kind: str) -> list[tuple[Path, str]]:
    """(folder, group) of every corpus character with a ``kind`` map."""
    out = []
    for folder in sorted(p for p in train.iterdir() if (p / "joints.json").is_file()):
        meta = json.loads((folder / "joints.json").read_text())
        if f"{kind}_map" not in meta:
            continue
        group = meta["parts"][0]["file"] if kind == "biped" else meta["standard_skeleton"].split()[0]
        out.append((folder, group))
    return out


def rig_and_score(score, gt, mesh: Path, template, options, out: Path):
    import autorig
    from autorig.exchange import write_rig
    rig = autorig.rig(mesh, template, options)
    write_rig(rig, out, "glb")
    result = score.score_glb(gt, str(out), kind=gt["kind"])
    return rig, result


def dealt(items: list[tuple[Path, str]], folds: int) -> dict[str, int]:
    """{group: fold} of the (folder, group) ``items``: the groups, sorted, dealt round-robin into ``folds``."""
    return {g: k % folds for k, g in enumerate(sorted({g for _, g in items}))}


def evaluate(kind: str, train: Path, folds: int, out_dir: Path, shared: Path, say, parts=None) -> list[dict]:
    sys.path.insert(0, str(shared / "tools"))
    import score
    import autorig
    from autorig.exchange import write_file_atomic
    from autorig.learn import PARTS, learn_template
    from autorig.template import load_template

    items = corpus(train, kind)
    fold_of = dealt(items, folds)
    handset = load_template(HANDSET / f"{kind}.json")
    rows = []
    for fold in range(folds):
        test = [(f, g) for f, g in items if fold_of[g] == fold]
        trained_on = [f for f, g in items if fold_of[g] != fold]
        start = time.perf_counter()
        learned = learn_template(trained_on, base=handset, name=kind, parts=parts or PARTS)
        template_path = out_dir / f"{kind}_fold{fold}.json"
        write_file_atomic(template_path, json.dumps(learned.template.to_dict()).encode())
        say(f"{kind} fold {fold + 1}/{folds}: learned from {len(trained_on)} in {time.perf_counter() - start:.0f} s")
        for folder, group in test:
            gt = score.load_gt(str(folder))
            row = {"model": folder.name, "group": group, "fold": fold}
            for label, template, options in (
                    ("before", handset, autorig.RigOptions(up="y", front="z")),
                    ("after", template_path, autorig.RigOptions(up="y", front="z")),
                    ("after_auto", template_path, autorig.RigOptions())):
                glb = out_dir / f"{folder.name}_{label}.glb"
                try:
                    rig, result = rig_and_score(score, gt, folder / "mesh.obj", template, options, glb)
                except Exception as e:    # a rig that fails is a result too
                    row[label] = {"error": str(e)}
                    continue
                row[label] = {"mean": 100 * result["joints"]["mean"], "max": 100 * result["joints"]["max"],
                              "worst": result["joints"]["worst"][0][0], "top1": result["weights"]["top1_pct"],
                              "confidence": rig.info["confidence"], "front": rig.info["front"],
                              "up": rig.info["up"], "joints": rig.joints}
                if kind == "quadruped":    # also apart from the species' trunk convention (issue 26)
                    row[label]["free"] = quadruped_score.score_glb(score, gt, glb)
            a = row.get("after", {})
            row["same_axes"] = _same(a, row.get("after_auto", {}), gt["height"])
            # The same character as files in other conventions: detection must find the same rig there.
            for label, (turn, axes) in TURNS.items():
                try:
                    rig = autorig.rig((turn(gt["V"]), gt["F"]), template_path, autorig.RigOptions())
                    row[label] = (rig.info["up"], rig.info["front"]) == axes
                except Exception:
                    row[label] = False
            rows.append(row)
            say(_line(row))
    return rows


# Turns of a +y up, +z front file into other conventions, each with the axes detection should find.
TURNS = {
    "facing_back": (lambda v: v * [-1, 1, -1], ("y", "-z")),
    "z_up": (lambda v: np.c_[v[:, 0], -v[:, 2], v[:, 1]], ("z", "-y")),
}


def _same(a: dict, b: dict, height: float) -> bool:
    """Whether two rigs' joints all lie within 1 % of the height of each other."""
    return ("joints" in a and "joints" in b
            and float(np.max(np.linalg.norm(a["joints"] - b["joints"], axis=1))) <= 0.01 * height)


def _cell(r: dict) -> str:
    if "error" in r:
        return f"{'failed':>27s}"
    return f"{r['mean']:5.1f} {r['max']:5.1f} {r['top1']:5.1f} {r['confidence']:5.2f}"


def _line(row: dict) -> str:
    wrong = "".join(f" {label}:WRONG" for label in TURNS if not row.get(label, True))
    free = "".join(f" | {label} {quadruped_score.line(row[label]['free'])}" for label in ("before", "after")
                   if "free" in row.get(label, {}))
    return (f"{row['model']:38s} {_cell(row.get('before', {'error': ''}))} | {_cell(row.get('after', {'error': ''}))} | "
            f"{_cell(row.get('after_auto', {'error': ''}))} {'same' if row['same_axes'] else 'DIFFERENT'}{wrong}{free}")


def summary(kind: str, rows: list[dict]) -> str:
    lines = [f"\n{kind}: {len(rows)} characters, {len({r['group'] for r in rows})} groups"]
    for label in ("before", "after", "after_auto"):
        ok = [r[label] for r in rows if "error" not in r.get(label, {"error": 1})]
        if not ok:
            continue
        means = np.array([r["mean"] for r in ok])
        maxes = np.array([r["max"] for r in ok])
        conf = np.array([r["confidence"] for r in ok])
        lines.append(f"  {label:10s} mean {means.mean():5.1f} %  (worst character's mean {means.max():5.1f})  "
                     f"worst joint {maxes.max():5.1f} %  (median {np.median(maxes):4.1f})  top-1 "
                     f"{np.mean([r['top1'] for r in ok]):5.1f} %  failed {len(rows) - len(ok)}  | confidence: "
                     f"{confidence_against_error(maxes, conf)}")
    lines += [free_summary(label, [r[label]["free"] for r in rows if "free" in r.get(label, {})],
                           [r[label]["confidence"] for r in rows if "free" in r.get(label, {})])
              for label in ("before", "after") if any("free" in r.get(label, {}) for r in rows)]
    n = len(rows)
    lines.append(f"  detected axes give the same rig: {sum(r['same_axes'] for r in rows)}/{n}; axes found for the mesh "
                 f"turned to face -z: {sum(r.get('facing_back', False) for r in rows)}/{n}; Z up, facing -y: "
                 f"{sum(r.get('z_up', False) for r in rows)}/{n}")
    return "\n".join(lines)


def free_summary(label: str, scores: list[dict], confidence: list[float]) -> str:
    """The rigs' ``quadruped_score.convention_free`` scores against issue 26's targets: limbs mean <= 5 %, every
    rig's worst limb joint <= 12 %, the artist's trunk joints within 6 % of the rig's trunk line; and their
    ``confidence`` judged on the limbs (worst limb joint > 20 % below 0.5, <= 10 % at 0.5 or above)."""
    means = np.array([s["limbs_mean"] for s in scores])
    worsts = np.array([s["limbs_worst"] for s in scores])
    trunks = np.array([s["trunk_worst"] for s in scores])
    return (f"  {label:10s} apart from the trunk convention: limbs mean {means.mean():5.1f} %  (worst character's "
            f"mean {means.max():5.1f})  worst limb joint {worsts.max():5.1f} %  (median {np.median(worsts):4.1f}; "
            f"{int(np.sum(worsts <= 12))}/{len(scores)} within 12 %)  trunk off the rig's line: worst "
            f"{trunks.max():5.1f} %  (median {np.median(trunks):4.1f}; {int(np.sum(trunks <= 6))}/{len(scores)} "
            f"within 6 %)  | confidence on the limbs: {confidence_against_error(worsts, np.array(confidence))}")


def confidence_against_error(maxes: np.ndarray, confidence: np.ndarray) -> str:
    """How the rigs' confidences [N] match their worst joint errors ``maxes`` [N] (% of the height): rigs more
    than 20 % off should score below 0.5, those within 10 % at 0.5 or above."""
    bad, good = maxes > 20, maxes <= 10
    return (f"{int(np.sum(bad & (confidence >= 0.5)))}/{int(bad.sum())} >20 % rigs at >= 0.5, "
            f"{int(np.sum(good & (confidence < 0.5)))}/{int(good.sum())} <=10 % rigs below 0.5")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--kinds", default="biped,quadruped")
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--out", type=Path, help="keep the templates and rigs here (default: a temporary folder)")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    parser.add_argument("--learn", help="what to learn, as autorig learn --learn (default: what the built-in "
                                        "template of each kind learned)")
    args = parser.parse_args(argv)
    train = args.shared / "data" / "train"
    if not train.is_dir():
        print(f"no corpus at {train}", file=sys.stderr)
        return 1
    print(f"{'model':38s} {'before: mean  max top1  conf':>27s} | {'after (axes given)':>27s} | "
          f"{'after (axes detected)':>27s}")
    all_rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        for kind in args.kinds.split(","):
            all_rows[kind] = evaluate(kind, train, args.folds, out_dir, args.shared, lambda s: print(s, flush=True),
                                      args.learn.split(",") if args.learn else shipped_parts(kind))
    for kind, rows in all_rows.items():
        print(summary(kind, rows))
    if args.json:
        args.json.write_text(json.dumps({k: [{**r, **{l: {kk: vv for kk, vv in r[l].items() if kk != "joints"}
                                                      for l in ("before", "after", "after_auto") if l in r}}
                                             for r in rows] for k, rows in all_rows.items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
