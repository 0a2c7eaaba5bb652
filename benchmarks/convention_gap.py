"""How far apart the engines' conventions are: the floor under any one default convention.

    python benchmarks/convention_gap.py [--shared ../shared] [--corpus ../corpus] [--per-source 4]

Two measures, both in % of the height:

- **The same bodies, two rigs.** A family of sources whose characters share their meshes (MakeHuman's bodies
  with its Mixamo rig and with its Unreal-style rig, ``learn.conventions.source_family``): each template joint's
  distance between the two artists' skeletons on the very same body. No rig, no learning: where two engines'
  artists disagree by d on a joint, a single convention is at least d / 2 from one of them there.
- **Each character in every shipped convention.** Up to ``--per-source`` characters of every source the
  built-in biped's engine convention is made of, rigged with the built-in biped (axes given) in each of its
  conventions and scored by ``shared/tools/score.py``: mean / worst joint error. The built-in biped learned from
  these characters, so the numbers are the conventions' own distances, not an estimate for unseen characters
  (``benchmarks/sources.py`` is that).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def same_bodies(items, score) -> list[str]:
    """Report lines: per family with two sources on the same bodies, each joint's mean and worst distance between
    the two rigs of one body (left and right joints together)."""
    from autorig.learn.conventions import source_family
    by_body = defaultdict(dict)
    for folder, source, group in items:     # a group is the characters sharing a body mesh (sources.examples)
        by_body[(source_family(source), group)][source] = folder
    pairs = defaultdict(list)
    for (family, _), rigs in sorted(by_body.items()):
        if len(rigs) == 2:
            (a, fa), (b, fb) = sorted(rigs.items())
            pairs[(a, b)].append((fa, fb))
    lines = []
    for (a, b), bodies in pairs.items():
        per_joint, means = defaultdict(list), []
        for fa, fb in bodies:
            ga, gb = score.load_gt(str(fa)), score.load_gt(str(fb))
            A, B = score.gt_template_joints(ga), score.gt_template_joints(gb)
            ds = {k: 100 * np.linalg.norm(A[k] - B[k]) / ga["height"] for k in A
                  if A[k] is not None and B.get(k) is not None}
            means.append(np.mean(list(ds.values())))
            for k, d in ds.items():
                per_joint[k.replace("left_", "").replace("right_", "")].append(d)
        lines.append(f"{a} against {b}, the same {len(bodies)} bodies: mean joint distance {np.mean(means):.2f} % "
                     f"(bodies {min(means):.2f}-{max(means):.2f})")
        lines += [f"  {k:10s} mean {np.mean(v):5.1f}  worst {np.max(v):5.1f}" for k, v in per_joint.items()]
    return lines


def every_convention(items, score, per_source: int, out: Path):
    """Report lines, one at a time as each character is rigged: characters of the engine convention's sources
    rigged in each of the built-in biped's conventions."""
    import autorig
    from autorig.exchange import write_rig
    from autorig.template import load_template
    template = load_template("biped")
    names = sorted(template.conventions)
    engine = set(template.conventions[template.default_convention]["sources"])
    taken = defaultdict(int)
    yield f"{'character':34s} " + "  ".join(f"{n:>11s}" for n in names)
    for folder, source, _ in items:
        if source not in engine or taken[source] >= per_source:
            continue
        taken[source] += 1
        meta = json.loads((folder / "joints.json").read_text())
        gt = score.load_gt(str(folder))
        cells = []
        for name in names:
            options = autorig.RigOptions(up=meta["up_axis"].lstrip("+"), front=meta["front_axis"].lstrip("+"),
                                         convention=name)
            path = out / f"{folder.name}_{name}.glb"
            write_rig(autorig.rig(folder / "mesh.obj", template, options), path, "glb")
            joints = score.score_glb(gt, str(path), kind="biped")["joints"]
            cells.append(f"{100 * joints['mean']:4.1f} / {100 * joints['max']:4.1f}")
        yield f"{folder.name[:34]:34s} " + "  ".join(f"{c:>11s}" for c in cells)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--per-source", type=int, default=4, help="characters rigged per source (default 4)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(args.shared / "tools"))
    import score
    from sources import examples
    items = examples(args.shared, args.corpus)
    print("\n".join(same_bodies(items, score)), flush=True)
    print("\nmean / worst joint error (% of height) in each convention of the built-in biped (in-sample):")
    with tempfile.TemporaryDirectory() as tmp:
        for line in every_convention(items, score, args.per_source, Path(tmp)):
            print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
