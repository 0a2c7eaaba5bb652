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

The same guesses are also scored apart from the trunk convention (``quadruped_score.convention_free``: limbs as
points, the artist's trunk joints against the guessed hips-spine-chest-neck-head line), as issue 26's targets
are. And since a line can only be so close to joints the artists put at different depths of the body, the last
table gives, for each trunk joint, how deep in the body each artist put it: the fraction of the body's depth at
that point (0 at the belly, 1 at the back: the lowest and highest surface crossings of the vertical line through
the joint), and the least worst error, as a fraction of the height, of any rule that puts the joint at one
fraction of the depth for every species (the best such fraction chosen with hindsight). Last, the artists'
joints that lie outside their own animal's mesh (by more than ``OUTSIDE`` of the height): a skeleton shared by
several meshes of a family and not fitted to this one.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

# An artist's joint this far outside the mesh (a fraction of the height) is not on the animal's body.
OUTSIDE = 0.01
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
                        "height": float(gt["height"]), "joints": joints,
                        "vertices": gt["V"] - origin, "faces": gt["F"]})
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
    return {key: float(np.linalg.norm(guess - animal["joints"][key]) / animal["height"])
            for key, guess in guessed(animal, examples).items()}


def column(vertices: np.ndarray, faces: np.ndarray, x: float, z: float) -> tuple[float, float] | None:
    """(lowest, highest) height where the vertical line through (x, z) crosses the mesh (vertices [V, 3],
    faces [F, 3]), or None if it misses: the legs stage's crossings (``legs.highest_crossings``), the lowest
    as the highest of the mesh upside down."""
    from autorig.readoff.legs import highest_crossings
    point = np.array([[x, z]], float)
    high = float(highest_crossings(vertices, faces, point)[0])
    if not np.isfinite(high):
        return None
    return -float(highest_crossings(vertices * [1.0, -1.0, 1.0], faces, point)[0]), high


def trunk_depths(every: list[dict]) -> dict[str, list[tuple[float, float]]]:
    """{trunk key: [(fraction of the body's depth at the joint, that depth / height)] over ``every`` animal
    that has the joint and whose vertical line through it crosses the mesh}."""
    from quadruped_score import TRUNK
    out: dict[str, list[tuple[float, float]]] = {}
    for animal in every:
        for key in TRUNK:
            p = animal["joints"].get(key)
            found = None if p is None else column(animal["vertices"], animal["faces"], float(p[0]), float(p[2]))
            if found is not None and found[1] > found[0]:
                low, high = found
                out.setdefault(key, []).append(((p[1] - low) / (high - low), (high - low) / animal["height"]))
    return out


def outside_joints(animal: dict) -> dict[str, float]:
    """{joint key: how far outside ``animal``'s mesh, as a fraction of the height} of its artist's joints more
    than ``OUTSIDE`` outside (the mesh's signed distance, ``autorig.discretize.distance.SurfaceQuery``)."""
    from autorig.discretize.distance import SurfaceQuery
    keys = list(animal["joints"])
    depth = SurfaceQuery(animal["vertices"], animal["faces"]).closest(np.array([animal["joints"][k] for k in keys]))[0]
    return {k: float(-d) / animal["height"] for k, d in zip(keys, depth) if -d > OUTSIDE * animal["height"]}


def best_fraction(rows: list[tuple[float, float]]) -> tuple[float, float]:
    """(fraction, worst error as a fraction of the height) of the one depth fraction that minimises the worst
    error over ``rows`` [(fraction, depth / height)]."""
    grid = np.linspace(0.0, 1.0, 1001)
    worst = np.max([np.abs(grid - f) * depth for f, depth in rows], axis=0)
    return float(grid[np.argmin(worst)]), float(worst.min())


def free_summary(every: list[dict], guesses: list[dict[str, np.ndarray]]) -> str:
    """Issue 26's convention-free score (``quadruped_score.convention_free``) of the guessed joints."""
    from quadruped_score import convention_free
    scores = [convention_free(a["joints"], g, a["height"]) for a, g in zip(every, guesses)]
    limbs = [s["limbs_mean"] for s in scores]
    worst = [s["limbs_worst"] for s in scores]
    trunk = [s["trunk_worst"] for s in scores if s["trunk_worst"] is not None]
    return (f"limbs mean {np.mean(limbs):.1f} %, worst limb joint {np.max(worst):.1f} % (median "
            f"{np.median(worst):.1f}; {sum(w <= 12 for w in worst)}/{len(worst)} within 12 %); trunk off the line: "
            f"worst {np.max(trunk):.1f} % (median {np.median(trunk):.1f}; {sum(t <= 6 for t in trunk)}/{len(trunk)} "
            f"within 6 %)")


def guessed(animal: dict, examples: list[dict]) -> dict[str, np.ndarray]:
    """{joint key: [3]} ``animal``'s joints put at the median of where the ``examples`` put them, in the paw
    frame (joints no example has are left out)."""
    out = {}
    for key in animal["joints"]:
        seen = [in_paw_frame(o, key) for o in examples if key in o["joints"]]
        if seen:
            out[key] = from_paw_frame(animal, np.median(seen, axis=0))
    return out


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
    held_out = [guessed(a, [o for o in every if o["group"] != a["group"]]) for a in every]
    print(f"\napart from the trunk convention (issue 26's score), held out: {free_summary(every, held_out)}")
    print(f"  with hindsight: {free_summary(every, [guessed(a, every) for a in every])}")
    print("\nhow deep in the body the artists put the trunk joints (0 belly, 1 back), and the least worst error of "
          "one fraction for all:")
    for key, rows in trunk_depths(every).items():
        fractions = np.array([f for f, _ in rows])
        best, worst = best_fraction(rows)
        print(f"  {key:6s} {len(rows):2d} animals: fraction {fractions.min():.2f}-{fractions.max():.2f} (median "
              f"{np.median(fractions):.2f}); best one fraction {best:.2f} leaves {100 * worst:.1f} % of the height")
    along = {a["name"]: 100 * (a["joints"]["hips"][2] - np.mean([a["joints"][f"back_{s}_hip"][2]
                                                              for s in ("left", "right")])) / a["height"]
             for a in every if all(k in a["joints"] for k in ("hips", "back_left_hip", "back_right_hip"))}
    behind, ahead = min(along, key=along.get), max(along, key=along.get)
    print(f"\nthe hips joint along the body from the hind legs' roots (% of the height, + forward): "
          f"{along[behind]:+.1f} ({behind}) to {along[ahead]:+.1f} ({ahead}), median {np.median(list(along.values())):+.1f}")
    print(f"\nthe artists' joints more than {100 * OUTSIDE:.0f} % of the height outside their own mesh:")
    for animal in every:
        out = outside_joints(animal)
        if out:
            print(f"  {animal['name']:22s} " + ", ".join(f"{k} {100 * v:.1f} %" for k, v in sorted(out.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
