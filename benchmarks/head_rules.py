"""The four-legged head rules alone (``autorig/readoff/head.py``), cross-validated, standing and with the head low.

    python benchmarks/head_rules.py [--shared ../shared] [--corpus ../corpus] [--cv species,source]
                                    [--rules skull,both] [--folds 4]

For each fold of ``animals.py``'s cross-validation (by species, by source) the head rules are learned from the
other animals standing (``learn_head``), and each held-out animal's head is read off its mesh by them with its
artist's own paws and shoulders (no embedding, no legs stage: the rules alone), standing and with its neck
lowered as ``animal_poses.py``'s "head low" poses it. ``--rules``: ``skull`` the skull rule alone, ``both`` the
skull rule with the frame rule beside it (what the templates learn). Printed per rig: the head's distance from
its artist's in % of the animal's largest extent standing; per rule, cross-validation and pose: mean, median,
worst, and how many beyond 10 and 15 %.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import animals  # noqa: E402  (puts the checkout's autorig first on the path)
from cross_validation import HANDSET  # noqa: E402

POSES = ("rest", "head low")


def main(argv=None) -> int:
    from autorig.discretize.surface import SurfaceQuery
    from autorig.learn.proportions import example_positions, fill_from_others, skeleton_of_base
    from autorig.readoff.head import learn_head, read_head
    from autorig.template import load_template

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=animals.ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=animals.ROOT.parent / "corpus")
    parser.add_argument("--cv", default="species,source")
    parser.add_argument("--rules", default="skull,both")
    parser.add_argument("--folds", type=int, default=4)
    args = parser.parse_args(argv)
    base = load_template(HANDSET / "quadruped.json")
    skeleton = skeleton_of_base(base)
    head = base.names.index("head")

    def truths(examples) -> np.ndarray:          # [N, J, 3] the examples' joints in the template frame
        return fill_from_others(np.array([example_positions(e, skeleton, base) for e in examples]),
                                skeleton.parents)

    found = animals.gather(args.shared, args.corpus, animals.ROOT / "data" / "maps", base)
    measured = {}                                # (name, pose) -> (example, depth, vertices, metres per unit)
    for animal in found:
        for pose in POSES:
            posed = animals.posed_animal(animal, pose)
            if posed is None:
                continue
            example = posed.example
            prepared = example.prepared()
            query = SurfaceQuery(prepared.work_vertices, prepared.work_faces)
            up = "xyz".index(example.up.lstrip("-"))
            metres = np.ptp(np.asarray(example.vertices)[:, up]) / np.ptp(prepared.work_vertices[:, 1])
            measured[animal.name, pose] = (example, (lambda p, q=query: q.closest(p)[0]), prepared.work_vertices,
                                           float(metres) / animal.extent)
    for rules in args.rules.split(","):
        for cv in args.cv.split(","):
            errors = {pose: [] for pose in POSES}
            for _, held, trained in animals.folds_of(found, cv, args.folds):
                examples = [a.example for a in trained]
                learned = learn_head(examples, truths(examples), base)[0]
                if rules == "skull":
                    learned = {"skull": learned["skull"]}
                template = replace(base, legs={**(base.legs or {}), "head": learned})
                for animal in held:
                    for pose in POSES:
                        if (animal.name, pose) not in measured:
                            continue
                        example, depth, vertices, scale = measured[animal.name, pose]
                        truth = truths([example])[0]
                        read = read_head(truth.copy(), template, depth, vertices)
                        error = 100 * float(np.linalg.norm(read[head] - truth[head])) * scale
                        errors[pose].append(error)
                        print(f"{rules:6s} {cv:8s} {animal.name:28s} {pose:9s} {error:6.1f}", flush=True)
            for pose, e in errors.items():
                e = np.array(e)
                print(f"{rules:6s} {cv:8s} {pose:9s} n {len(e)}  mean {e.mean():.1f}  median {np.median(e):.1f}  "
                      f"worst {e.max():.1f}  beyond 10: {(e > 10).sum()}  beyond 15: {(e > 15).sum()}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
