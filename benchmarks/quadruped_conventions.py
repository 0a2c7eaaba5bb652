"""How much of a quadruped rig's error is the artists' convention: joints predicted from the true limb ends.

    python benchmarks/quadruped_conventions.py [--shared ../shared]

The corpus's animals come from many skeletons, one per species or family, and each skeleton's artist put the
trunk joints (pelvis, spines, neck, the tops of the legs) by a convention of their own: a bear's pelvis at its
rump, a tiger's hip joints on its spine. No rig made from the mesh alone can know a convention it has not seen.
This measures how far even a rig that knew every true paw would be, with no embedding at all:

    each joint of a held-out group (``cross_validation.corpus``: every animal sharing a skeleton) is put where
    the other groups' artists put it, by the median of their joints in a frame fixed by the true paws:
        x   as a fraction of the mesh's width (0 on the mid-plane)
        y   as a fraction of the height
        z   from the back paws' midpoint (0) to the front paws' (1)

and scored as ``shared/tools/score.py`` scores a rig (error as a fraction of the height). The paws' position
along the body is right by construction. A last line does the same with hindsight: the medians taken over
every animal, the held-out one's own group included, as if its convention were already known. It is not a
bound on every possible method (one might read a convention off the mesh), but it shows how far apart the
species' own conventions put the trunk joints.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

PAWS = (("back_left_paw", "back_right_paw"), ("front_left_paw", "front_right_paw"))


def animals(shared: Path) -> list[dict]:
    """Each corpus animal with both pairs of paws: its group, width, height and joints {key: [3]} with x
    measured from the middle of the mesh's width and y from its lowest point."""
    sys.path.insert(0, str(shared / "tools"))
    import score
    from cross_validation import corpus
    out = []
    for folder, group in corpus(shared / "data" / "train", "quadruped"):
        gt = score.load_gt(str(folder))
        lo, hi = gt["V"].min(axis=0), gt["V"].max(axis=0)
        origin = np.array([(lo[0] + hi[0]) / 2, lo[1], 0.0])
        index = {n: i for i, n in enumerate(gt["joint_names"])}
        joints = {k: gt["joint_pos"][index[n]] - origin for k, n in gt["map"].items() if n is not None}
        if all(p in joints for pair in PAWS for p in pair):
            out.append({"name": folder.name, "group": group, "width": float(hi[0] - lo[0]),
                        "height": float(gt["height"]), "joints": joints})
    return out


def _paws_z(animal: dict) -> tuple[float, float]:
    back, front = ([animal["joints"][p][2] for p in pair] for pair in PAWS)
    return float(np.mean(back)), float(np.mean(front))


def in_paw_frame(animal: dict, key: str) -> np.ndarray:
    """[3] joint ``key`` of ``animal`` in the frame fixed by its paws."""
    back, front = _paws_z(animal)
    p = animal["joints"][key]
    return np.array([p[0] / animal["width"], p[1] / animal["height"], (p[2] - back) / (front - back)])


def from_paw_frame(animal: dict, q: np.ndarray) -> np.ndarray:
    back, front = _paws_z(animal)
    return np.array([q[0] * animal["width"], q[1] * animal["height"], back + q[2] * (front - back)])


def convention_errors(animal: dict, examples: list[dict]) -> dict[str, float]:
    """{joint key: error as a fraction of the height} of ``animal``'s joints put at the median of where the
    ``examples`` put them, in the paw frame (joints no example has are left out)."""
    errors = {}
    for key, truth in animal["joints"].items():
        seen = [in_paw_frame(o, key) for o in examples if key in o["joints"]]
        if seen:
            guess = from_paw_frame(animal, np.median(seen, axis=0))
            errors[key] = float(np.linalg.norm(guess - truth) / animal["height"])
    return errors


def summary(errors: list[dict[str, float]]) -> str:
    means = [np.mean(list(e.values())) for e in errors]
    worsts = [max(e.values()) for e in errors]
    return (f"mean {100 * np.mean(means):.1f} %, worst character's mean {100 * np.max(means):.1f} %, worst joint "
            f"{100 * np.max(worsts):.1f} % (median {100 * np.median(worsts):.1f}); "
            f"{sum(w <= 0.12 for w in worsts)}/{len(worsts)} animals with every joint within 12 %")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args(argv)
    every = animals(args.shared)
    per_key: dict[str, list[float]] = {}
    left_out = []
    print(f"{'animal':24s} {'mean %':>7s} {'worst %':>8s}  worst joint")
    for animal in every:
        errors = convention_errors(animal, [o for o in every if o["group"] != animal["group"]])
        for key, value in errors.items():
            per_key.setdefault(key, []).append(value)
        left_out.append(errors)
        worst = max(errors, key=errors.get)
        print(f"{animal['name']:24s} {100 * np.mean(list(errors.values())):7.1f} {100 * errors[worst]:8.1f}  {worst}")
    print(f"\n{len(every)} animals, {len({a['group'] for a in every})} groups: {summary(left_out)}")
    print("\nmean error by joint (%):")
    for key, values in sorted(per_key.items(), key=lambda kv: -np.mean(kv[1])):
        print(f"  {key:22s} {100 * np.mean(values):5.1f}")
    hindsight = [convention_errors(animal, every) for animal in every]
    print(f"\nwith hindsight (each animal's own group among the medians): {summary(hindsight)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
