"""Every four-legged animal with an artist's rig, rigged by a template learned without its species or its source.

    python benchmarks/animals.py [--shared ../shared] [--corpus ../corpus] [--templates quadruped,horse]
                                 [--cv species,source] [--axes given,detected] [--turns none,facing_back,z_up]
                                 [--poses "rest;walk;head low;walk, head low"]
                                 [--only NAME,...] [--limit N] [--folds 4] [--json FILE] [--quiet]

The animals: 0 A.D.'s (``shared/data/train``, their ``quadruped_map``), the shared Fox (``shared/data/rigged``),
OpenClonk's wipf, mooq and puka (``shared/data/more`` with the maps of ``data/maps/``) and any corpus folder
(``../corpus``, e.g. written by ``data/corpus/*.py``) whose ``joints.json`` has a ``quadruped_map``.

Cross-validation (``--cv``): by species (the species groups, e.g. the cattle family or the two foxes, dealt into
``--folds`` as ``benchmarks/cross_validation.py`` deals them) and by source (each source held out in turn). For
each fold and template the template's learned parts (what the built-in one learned: ``cross_validation.
shipped_parts``) are relearned from the other animals on the hand-set template (``templates/handset/``), and
each held-out animal is rigged with the axes given and detected, as its file is (``none``), and with the axes
detected (given too with ``--turned-given``) turned to face -z (``facing_back``) and turned Z-up, facing -y
(``z_up``).

``--poses``: each held-out animal also re-posed through its artist's weights (``animal_poses``: walking, the
head low, both), scored against its artist's joints moved with the skeleton and its extent as it stood.

Scored per rig, against the artist's joints, in % of the animal's largest extent (its height or its length):
structure right when each paw and the head lies nearer its own artist's joint than any other of the five, and
within 15 % of it (a leg whose artist gave no paw joint ends at its lowest mapped joint: the wrist, ankle or
elbow); the anatomy joints (elbows, wrists, knees, hocks, paws, head: those the artist has) mean and worst; the
rig's confidence. The summary per template, cross-validation and axes: structures right n/N, anatomy mean and
worst (all rigs, and the right ones), and the wrong structures that score confidence >= 0.5. ``--json`` writes
every row (to diff a before and an after).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import animal_poses  # noqa: E402
from cross_validation import HANDSET, dealt, shipped_parts  # noqa: E402

LEGS = ("front_left", "front_right", "back_left", "back_right")
# the joints a leg may end at, lowest first
LOWEST = {"front": ("paw", "wrist", "elbow"), "back": ("paw", "ankle", "knee")}
ANATOMY = tuple(f"{leg}_{j}" for leg in LEGS for j in LOWEST[leg.split("_")[0]]) + ("head",)
STRUCTURE_LIMIT = 15.0    # % of the largest extent
# Turns of a +y up, +z front file into other conventions, with the axes to give for them.
TURNS = {
    "none": (lambda v: v, ("y", "z")),
    "facing_back": (lambda v: v * [-1, 1, -1], ("y", "-z")),
    "z_up": (lambda v: np.c_[v[:, 0], -v[:, 2], v[:, 1]], ("z", "-y")),
}


@dataclass
class Animal:
    name: str
    source: str
    species: str
    example: object          # autorig.learn.examples.Example
    rest_extent: float | None = None   # a re-posed animal's: scored against its extent as it stood

    @property
    def extent(self) -> float:
        """The animal's largest extent: its height or its length (along its own up and front axes)."""
        if self.rest_extent is not None:
            return self.rest_extent
        ex = self.example
        span = np.ptp(ex.vertices, axis=0)
        return float(max(span["xyz".index(ex.up.lstrip("-"))], span["xyz".index(ex.front.lstrip("-"))]))

    def truth(self) -> dict[str, np.ndarray]:
        ex = self.example
        return {key: np.asarray(ex.positions[j], float) for key, j in ex.key_of.items()}


def end_keys(truth: dict) -> dict[str, str]:
    """{leg or "head": the template joint its end is scored at}: each leg's lowest joint the artist has."""
    out = {}
    for leg in LEGS:
        key = next((f"{leg}_{j}" for j in LOWEST[leg.split("_")[0]] if f"{leg}_{j}" in truth), None)
        if key is not None:
            out[leg] = key
    if "head" in truth:
        out["head"] = "head"
    return out


def score(rig: dict[str, np.ndarray], truth: dict[str, np.ndarray], extent: float) -> dict:
    """A rig's joints {template name: position} against the artist's, both in one frame, in % of ``extent``.

    structure: every end (the four legs' lowest joints and the head) right: nearer its own artist's joint than
    any other end's, and within ``STRUCTURE_LIMIT`` % of it; ends: {end: {error, nearest, right}};
    anatomy_mean / anatomy_worst / worst_joint over the anatomy joints the artist has."""
    ends = end_keys(truth)
    per_end = {}
    for label, key in ends.items():
        if key not in rig:
            per_end[label] = {"error": None, "nearest": None, "right": False}
            continue
        d = {other: 100 * float(np.linalg.norm(rig[key] - truth[k])) / extent for other, k in ends.items()}
        nearest = min(d, key=d.get)
        per_end[label] = {"error": d[label], "nearest": nearest,
                          "right": nearest == label and d[label] <= STRUCTURE_LIMIT}
    errors = {key: 100 * float(np.linalg.norm(rig[key] - truth[key])) / extent
              for key in ANATOMY if key in truth and key in rig}
    worst = max(errors, key=errors.get) if errors else None
    return {"structure": bool(per_end) and len(per_end) == 5 and all(e["right"] for e in per_end.values()),
            "ends": per_end, "anatomy": errors,
            "anatomy_mean": float(np.mean(list(errors.values()))) if errors else None,
            "anatomy_worst": errors[worst] if worst else None, "worst_joint": worst}


def gather(shared: Path, corpus: Path | None, maps: Path, base) -> list[Animal]:
    """Every four-legged animal with a quadruped map (see the module's docstring), in name order per source."""
    from autorig.learn.conventions import source_of
    from autorig.learn.examples import read_example, read_mapped_gltf
    out = []
    folders = [(p, "0ad") for p in sorted((shared / "data" / "train").glob("*/joints.json"))]
    folders += [(p, "rigged") for p in sorted((shared / "data" / "rigged").glob("*/joints.json"))]
    if corpus is not None and corpus.is_dir():
        folders += [(p, None) for p in sorted(corpus.glob("*/joints.json"))]
    for joints, source in folders:
        meta = json.loads(joints.read_text())
        if not isinstance(meta.get("quadruped_map"), dict):
            continue
        example = read_example(joints.parent, base)
        if example is None:
            continue
        example.source = source_of(example, joints.parent)
        if source == "0ad":    # a species family: the skeleton its artists shared (bovidae, ursidae, boar, ...)
            species = Path(meta["standard_skeleton"].split()[0]).stem.split("_")[0]
        else:
            species = str(meta.get("species") or joints.parent.name.split("_")[-1]).lower()
        out.append(Animal(joints.parent.name, source or example.source, species, example))
    for map_file in sorted(maps.glob("*.json")):
        meta = json.loads(map_file.read_text())
        glb = shared / "data" / "more" / map_file.stem / "model.glb"
        if meta.get("category") != "quadruped" or not glb.is_file():
            continue
        example = read_mapped_gltf(glb, map_file, base)
        out.append(Animal(map_file.stem, example.source, meta["species"], example))
    return out


def folds_of(animals: list[Animal], cv: str, folds: int) -> list[tuple[str, list[Animal], list[Animal]]]:
    """[(fold label, held out, trained on)] for cross-validation by ``species`` or by ``source``."""
    if cv == "species":
        fold_of = dealt([(a.name, a.species) for a in animals], folds)
        labels = sorted(set(fold_of.values()))
        return [(f"species fold {k + 1}", [a for a in animals if fold_of[a.species] == k],
                 [a for a in animals if fold_of[a.species] != k]) for k in labels]
    return [(f"source {s}", [a for a in animals if a.source == s], [a for a in animals if a.source != s])
            for s in sorted({a.source for a in animals})]


def posed_animal(animal: Animal, pose: str) -> Animal | None:
    """``animal`` re-posed (``animal_poses``), scored against its extent at rest; itself for "rest"."""
    if pose == "rest":
        return animal
    example = animal_poses.posed_example(animal.example, pose)
    return None if example is None else Animal(animal.name, animal.source, animal.species, example, animal.extent)


def rig_animal(animal: Animal, template_path: Path, turn: str, axes: str) -> dict:
    import autorig
    ex = animal.example
    if (ex.up, ex.front) != ("y", "z") and turn != "none":
        return {"skipped": f"turns need a +y up, +z front file ({ex.up}, {ex.front})"}
    move, given = TURNS[turn] if turn != "none" else (TURNS["none"][0], (ex.up, ex.front))
    options = autorig.RigOptions(up=given[0], front=given[1]) if axes == "given" else autorig.RigOptions()
    truth = {k: move(p[None])[0] for k, p in animal.truth().items()}
    start = time.perf_counter()
    try:
        rig = autorig.rig((move(np.asarray(ex.vertices, float)), ex.faces), template_path, options)
    except Exception as e:    # a rig that fails is a result too: its structure is wrong
        return {"error": f"{type(e).__name__}: {e}", "structure": False, "confidence": None}
    result = score(dict(zip(rig.names, np.asarray(rig.joints, float))), truth, animal.extent)
    result.update(confidence=float(rig.info["confidence"]), axes_found=[rig.info["up"], rig.info["front"]],
                  axes_right=(rig.info["up"], rig.info["front"]) == tuple(given),
                  seconds=time.perf_counter() - start)
    return result


def line(row: dict) -> str:
    r = row["result"]
    head = (f"{row['model']:28s} {row['source']:9s} {row['species']:12s} {row['template']:9s} {row['cv']:7s} "
            f"{row['turn']:11s} {row['axes']:8s}{'' if row.get('pose', 'rest') == 'rest' else ' ' + row['pose']}")
    if "skipped" in r:
        return f"{head} skipped: {r['skipped']}"
    if "error" in r:
        return f"{head} FAILED {r['error']}"
    wrong = [f"{end}->{e['nearest']}" if e["nearest"] != end else f"{end} {e['error']:.0f}%"
             for end, e in r["ends"].items() if not e["right"]]
    axes = "" if r["axes_right"] else f" axes {r['axes_found'][0]},{r['axes_found'][1]}"
    return (f"{head} {'right' if r['structure'] else 'WRONG'} {r['anatomy_mean']:5.1f} {r['anatomy_worst']:5.1f} "
            f"{r['confidence']:5.2f}{axes}{'  ' + ' '.join(wrong) if wrong else ''}")


def summary(rows: list[dict]) -> list[str]:
    """One line per template, cross-validation, axes and turn (over every animal)."""
    def label(r):
        turn, pose = r.get("turn", "none"), r.get("pose", "rest")
        return (r["axes"] if turn == "none" else f"{r['axes']}/{turn}") + ("" if pose == "rest" else f" {pose}")

    def mean_worst(rs):
        if not rs:
            return "    -      -"
        return (f"{np.mean([x for r in rs for x in r['anatomy'].values()]):5.1f} "
                f"{max(r['anatomy_worst'] for r in rs):6.1f}")

    out = [f"{'template':9s} {'cv':7s} {'axes':20s} {'right':>7s} {'anatomy mean':>12s} {'worst':>6s} "
           f"{'(right ones: mean':>17s} {'worst)':>6s} {'wrong at >= 0.5':>15s} {'failed':>6s}"]
    order = {"given": 0, "detected": 1, "given/facing_back": 2, "given/z_up": 3, "detected/facing_back": 4,
             "detected/z_up": 5}
    keys = sorted({(r["template"], r["cv"], label(r)) for r in rows},
                  key=lambda k: (k[0], k[1], order.get(k[2].split(" ")[0], 9), k[2]))
    for template, cv, axes in keys:
        group = [r["result"] for r in rows if (r["template"], r["cv"], label(r)) == (template, cv, axes)
                 and "skipped" not in r["result"]]
        ok = [r for r in group if "error" not in r]
        right = [r for r in ok if r["structure"]]
        wrong_confident = [r for r in ok if not r["structure"] and r["confidence"] >= 0.5]
        out.append(f"{template:9s} {cv:7s} {axes:20s} {len(right):3d}/{len(group):<3d} {mean_worst(ok):>19s} "
                   f"{mean_worst(right):>24s} {len(wrong_confident):3d}/{len(group) - len(right):<11d} "
                   f"{len(group) - len(ok):6d}")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--maps", type=Path, default=ROOT / "data" / "maps")
    parser.add_argument("--templates", default="quadruped,horse")
    parser.add_argument("--cv", default="species,source", help="species, source or both")
    parser.add_argument("--axes", default="given,detected")
    parser.add_argument("--turns", default="none,facing_back,z_up", help=f"of {', '.join(TURNS)}")
    parser.add_argument("--poses", default="rest",
                        help="poses, separated by ';': rest and any of " + "; ".join(animal_poses.POSES))
    parser.add_argument("--only", help="rig only these animals (comma-separated names; the others still teach)")
    parser.add_argument("--limit", type=int, help="rig only the first N animals of each fold")
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--turned-given", action="store_true",
                        help="also rig the turned files with their axes given (default: detected only; given axes "
                             "name the same frame as the file's own)")
    parser.add_argument("--json", type=Path, help="write every row here (after each fold)")
    parser.add_argument("--summary-from", type=Path, help="print the summary of a --json file and stop")
    parser.add_argument("--quiet", action="store_true", help="print the summary only")
    args = parser.parse_args(argv)
    if args.summary_from:
        print("\n".join(summary(json.loads(args.summary_from.read_text()))))
        return 0
    lists = {k: [x.strip() for x in getattr(args, k).split(",") if x.strip()]
             for k in ("templates", "cv", "axes", "turns")}
    lists["poses"] = [x.strip() for x in args.poses.split(";") if x.strip()]    # pose names hold commas
    bad = ([t for t in lists["turns"] if t not in TURNS] + [c for c in lists["cv"] if c not in ("species", "source")]
           + [p for p in lists["poses"] if p != "rest" and p not in animal_poses.POSES]
           + [a for a in lists["axes"] if a not in ("given", "detected")])
    if bad:
        print(f"error: unknown {', '.join(bad)}", file=sys.stderr)
        return 2
    if not (args.shared / "data" / "train").is_dir():
        print(f"error: no corpus at {args.shared / 'data' / 'train'}", file=sys.stderr)
        return 1
    from autorig.exchange import write_file_atomic
    from autorig.learn import learn_template
    from autorig.template import load_template
    animals = gather(args.shared, args.corpus, args.maps, load_template(HANDSET / "quadruped.json"))
    only = set(args.only.split(",")) if args.only else None
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    say(f"{len(animals)} animals: " + ", ".join(f"{a.name} ({a.source}, {a.species})" for a in animals))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for template in lists["templates"]:
            handset = load_template(HANDSET / f"{template}.json")
            for cv in lists["cv"]:
                for label, held, trained in folds_of(animals, cv, args.folds):
                    held = [a for a in held if only is None or a.name in only][:args.limit]
                    if not held:
                        continue
                    start = time.perf_counter()
                    learned = learn_template([a.example for a in trained], base=handset, name=template,
                                             parts=shipped_parts(template))
                    path = Path(tmp) / f"{template}_{cv}_{label.replace(' ', '_')}.json"
                    write_file_atomic(path, json.dumps(learned.template.to_dict()).encode())
                    say(f"{template} {label}: learned from {len(trained)} in {time.perf_counter() - start:.0f} s")
                    for animal, pose in ((a, p) for a in held for p in lists["poses"]):
                        posed = posed_animal(animal, pose)
                        for turn in lists["turns"]:
                            for axes in lists["axes"]:
                                if turn != "none" and axes == "given" and not args.turned_given:
                                    continue
                                row = {"model": animal.name, "source": animal.source, "species": animal.species,
                                       "template": template, "cv": cv, "fold": label, "turn": turn, "axes": axes,
                                       "pose": pose, "result": rig_animal(posed, path, turn, axes) if posed else
                                       {"skipped": f"its artist has no joint to turn for {pose}"}}
                                rows.append(row)
                                say(line(row))
                    if args.json:
                        write_file_atomic(args.json, json.dumps(rows, indent=1).encode())
    print("\n".join(summary(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
