"""Leave-one-source-out cross-validation of the learned biped: learn from the other studios, rig the one left out.

    python benchmarks/sources.py [--shared ../shared] [--corpus ../corpus] [--folds 4] [--json FILE]

The examples are what ``templates/retrain.sh`` learns the biped from: the 0 A.D. corpus (``shared/data/train``),
the shared artists' rigs (``shared/data/rigged``) and the corpora the converters under ``data/corpus/`` build
(``../corpus``: MakeHuman's bodies with its Mixamo rig, Lugaru's rabbit and wolf). Each example's source is the
learner's (``autorig.learn.conventions.source_of``) and so is its convention (the built-in biped's
``learned_from`` record says which sources share one, as the glTF samples and MakeHuman's Mixamo rig share the
engines').

- Every source but 0 A.D. is held out whole (with the sources that share its bodies: ``makehuman`` and
  ``makehuman-ue`` are the same bodies under two rigs): a template is learned from all the others the built-in
  biped learns from (its ``learned_from`` record's sources; a source it does not learn from is a test only), and
  each held-out character is rigged in the default convention (the engines') and, if another source follows
  its convention, in that one too.
- 0 A.D. is held out by group, as ``cross_validation.py`` does (characters sharing a body
  mesh together, ``--folds`` folds), with every other source in each fold's training set, and rigged in its own
  convention and in the default.

Each rig is made with the axes given (each character's own, from its joints.json) and scored by ``shared/tools/score.py``. Reported per
source and convention: mean and worst joint error (% of the height), weight top-1, and the confidence against
the true error (rigs whose worst joint is more than 20 % off should score below 0.5, those within 10 % at 0.5 or
above).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
HANDSET = ROOT / "templates" / "handset" / "biped.json"


def shipped_record(template: Path = ROOT / "templates" / "biped.json") -> dict:
    """The built-in biped's ``learned_from`` record (or another template's): what it learned and which
    sources its named conventions hold."""
    return json.loads(Path(template).read_text())["learned_from"]


def examples(shared: Path, corpus: Path) -> list[tuple[Path, str, str]]:
    """(folder, source, group) of every biped example: groups share a body mesh (0 A.D.'s first part file;
    one MakeHuman body under both rigs), else each character is its own."""
    from types import SimpleNamespace

    from autorig.learn.conventions import source_of
    out = []
    for root in (shared / "data" / "train", shared / "data" / "rigged", corpus):
        if not root.is_dir():
            continue
        for folder in sorted(p for p in root.iterdir() if (p / "joints.json").is_file()):
            meta = json.loads((folder / "joints.json").read_text())
            if "biped_map" not in meta:
                continue
            parts = meta.get("parts") or []
            # The source needs only the folder's name and joints.json, not its mesh.
            source = source_of(SimpleNamespace(name=folder.name, meta=meta), folder)
            body = folder.name[len(source) + 1:] if folder.name.startswith(source + "_") else folder.name
            group = str(parts[0].get("file")) if parts and isinstance(parts[0], dict) else body
            out.append((folder, source, group))
    return out


def plan(items, folds: int, learned: set[str] | None = None, by_group: str = "0ad"
         ) -> list[tuple[str, list[Path], list[Path]]]:
    """[(held-out family of sources, training folders, test folders)]: ``by_group`` (0 A.D.) by group folds,
    as cross_validation.py holds it out, every other whole; only the ``learned`` sources (all for None) are
    ever trained on. A held-out family (``learn.conventions.source_family``) is its sources that share bodies."""
    from autorig.learn.conventions import source_family
    by_source = defaultdict(list)
    for folder, source, group in items:
        by_source[source_family(source)].append((folder, group))
    out = []
    for source, members in sorted(by_source.items()):
        others = [f for f, s, _ in items if source_family(s) != source and (learned is None or s in learned)]
        if source != by_group:
            out.append((source, others, [f for f, _ in members]))
            continue
        groups = sorted({g for _, g in members})
        fold_of = {g: k % folds for k, g in enumerate(groups)}
        for fold in range(folds):
            out.append((source, others + [f for f, g in members if fold_of[g] != fold],
                        [f for f, g in members if fold_of[g] == fold]))
    return out


def evaluate(shared: Path, corpus: Path, folds: int, out_dir: Path, say, record: dict | None = None,
             only: set[str] | None = None) -> list[dict]:
    sys.path.insert(0, str(shared / "tools"))
    import score
    import autorig
    from autorig.exchange import write_file_atomic, write_rig
    from autorig.learn import learn_template
    from autorig.learn.conventions import convention_for_source, source_of
    from autorig.learn.examples import read_example
    from autorig.template import load_template

    record = record or shipped_record()
    items = examples(shared, corpus)
    base = load_template(HANDSET)
    rows = []
    for n, (source, train, test) in enumerate(plan(items, folds, set(record.get("sources") or {}) or None)):
        if only and source not in only:
            continue
        start = time.perf_counter()
        learned = learn_template(train, base=base, name="biped", parts=record["learned"],
                                 conventions=record.get("conventions"), default=record.get("default_convention"))
        template = learned.template
        path = out_dir / f"biped_{n}.json"
        write_file_atomic(path, json.dumps(template.to_dict()).encode())
        say(f"without {source} ({len(test)} held out): learned from {len(train)} in "
            f"{time.perf_counter() - start:.0f} s; conventions {sorted(template.conventions or {})}")
        for folder in test:
            example = read_example(folder, base)
            source = source_of(example, folder)
            own = convention_for_source(template.conventions or {}, source)
            axes = {"up": example.up, "front": example.front}
            gt = score.load_gt(str(folder))
            asked = [template.default_convention]
            if own in (template.conventions or {}) and own != template.default_convention:
                asked.append(own)
            for convention in asked:
                row = {"model": folder.name, "source": source, "convention": convention,
                       "own": convention == own}
                try:
                    rig = autorig.rig(folder / "mesh.obj", path, autorig.RigOptions(**axes, convention=convention))
                    out = out_dir / f"{folder.name}_{convention}.glb"
                    write_rig(rig, out, "glb")
                    result = score.score_glb(gt, str(out), kind="biped")
                    row.update(mean=100 * result["joints"]["mean"], max=100 * result["joints"]["max"],
                               worst=result["joints"]["worst"][0][0], top1=result["weights"]["top1_pct"],
                               confidence=rig.info["confidence"])
                except Exception as e:    # a rig that fails is a result too
                    row["error"] = str(e)
                rows.append(row)
                say(line(row))
    return rows


def line(row: dict) -> str:
    if "error" in row:
        return f"  {row['model']:36s} {row['convention']:9s} failed: {row['error']}"
    return (f"  {row['model']:36s} {row['convention']:9s} mean {row['mean']:5.1f}  max {row['max']:5.1f} "
            f"({row['worst']})  top-1 {row['top1']:5.1f}  confidence {row['confidence']:4.2f}")


def summary(rows: list[dict]) -> str:
    from cross_validation import confidence_against_error
    lines = ["\nbiped, leave one source out (mean / worst joint % of height, weight top-1 %, confidence):"]
    keys = sorted({(r["source"], r["convention"], r["own"]) for r in rows})
    for source, convention, own in keys:
        mine = [r for r in rows if (r["source"], r["convention"], r["own"]) == (source, convention, own)]
        ok = [r for r in mine if "error" not in r]
        if not ok:
            lines.append(f"  {source:10s} in {convention:8s}: all {len(mine)} failed")
            continue
        means, maxes = np.array([r["mean"] for r in ok]), np.array([r["max"] for r in ok])
        conf = np.array([r["confidence"] for r in ok])
        worst = ok[int(np.argmax(maxes))]
        lines.append(f"  {source:10s} in {convention:8s}{' (its own)' if own else '          '}: {len(ok):2d} rigs  "
                     f"mean {means.mean():4.1f} %  (worst character's {means.max():4.1f})  worst joint "
                     f"{maxes.max():5.1f} % ({worst['model']} {worst['worst']})  top-1 "
                     f"{np.mean([r['top1'] for r in ok]):5.1f} %  failed {len(mine) - len(ok)}  | confidence "
                     f"{conf.min():.2f}-{conf.max():.2f}: {confidence_against_error(maxes, conf)}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus",
                        help="the corpora built by data/corpus/*.py (default ../corpus)")
    parser.add_argument("--folds", type=int, default=4)
    parser.add_argument("--out", type=Path, help="keep the templates and rigs here (default: a temporary folder)")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    parser.add_argument("--sources", help="hold out only these sources (comma-separated; default: every one)")
    parser.add_argument("--like", type=Path, default=ROOT / "templates" / "biped.json",
                        help="learn what this template learned (its learned_from record; default the built-in biped)")
    args = parser.parse_args(argv)
    if not args.corpus.is_dir():
        print(f"no corpus at {args.corpus}: only the shared sources are held out "
              f"(python data/corpus/makehuman.py and data/corpus/lugaru.py build the others)", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out or Path(tmp)
        out_dir.mkdir(parents=True, exist_ok=True)
        rows = evaluate(args.shared, args.corpus, args.folds, out_dir, lambda s: print(s, flush=True),
                        shipped_record(args.like), set(args.sources.split(",")) if args.sources else None)
    print(summary(rows))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
