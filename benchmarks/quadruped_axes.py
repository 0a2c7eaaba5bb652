"""Head and tail with detected axes on four-legged animals outside the corpus, made by code.

    python benchmarks/quadruped_axes.py [--per-family 6] [--families cartoon,realistic,long_legged,low]
                                        [--template quadruped] [--seed 26] [--save DIR]

A fixed, seeded family of parametric animals, each the smooth union of ellipsoids and tapered capsules
(``autorig.samples``' primitives, meshed by marching cubes: one closed surface), built +y up, facing +z:

- cartoon: a big head on a short neck or none, straight over the front legs; stubby legs; ears or horns; a long
  raised tail, a bushy one, a curled-up one or none;
- realistic: a long neck carried forward, a moderate head with a muzzle, small ears, a thin tail hanging;
- long_legged: horse- or giraffe-like, long legs and a long raised neck, a small head, a short thin tail;
- low: dachshund- or crocodile-like, short legs under a long body, a long low snout, a thick tapering tail or a
  thin one.

Every proportion is drawn uniformly from its family's range (wide on purpose, both ways of each cue: a big head
with no reach, a tail that reaches far and ends high). Knees point forward and hocks back, elbows back and
wrists forward, as in the animals the cues are about.

This family is a HELD-OUT CHECK: nothing in autorig is fitted to it (the orientation cues' weights are learned
from the corpus by ``autorig learn``, ``autorig/learn/head_tail.py``); do not tune a constant to it.

Each animal is rigged with ``--template quadruped`` and detected axes in four turns (as built; facing -z; facing
+x; Z up facing -y). Right: the detected up is the true up and the rig's ``head`` joint lies nearer the true head
than the true rump. Printed: per animal and turn, then per family and turn, right / reversed / upside down (or
sideways).

``--explain`` prints instead why, per animal as built (and per corpus animal with ``--corpus``): the embedding's
penalty facing backwards minus facing the right way (both searched as long as detection searches its two best
frames; negative: the embedding alone turns it round), the outline cue (``orient.head_tail_cue``), the limb
ends' bulk cue (``ends.end_bulk_cue``), the weight share (``ends.weight_share_cue``: where the medial spheres'
volume lies between the back and front feet, -1 over the back feet, +1 over the front ones), the crest
(``orient.crest_cue``: where the top of the shape lies between them), the feet (``ends.toes_cue``: how far the
soles reach forward of the legs), and what the template's weights make of
them (2 w . cues: the prior's difference between the two frames; the embedding's difference counts at most the
template's ``head_gap``).
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from autorig.samples import _Cone, _Ellipsoid, _frame, _mesh, _unit

FAMILIES = ("cartoon", "realistic", "long_legged", "low")

# (name, turn of a +y up +z front vertex array [V, 3], the axes detection should find)
TURNS = [
    ("as built", lambda v: v, ("y", "z")),
    ("facing -z", lambda v: v * [-1, 1, -1], ("y", "-z")),
    ("facing +x", lambda v: np.c_[v[:, 2], v[:, 1], -v[:, 0]], ("y", "x")),
    ("Z up, facing -y", lambda v: np.c_[v[:, 0], -v[:, 2], v[:, 1]], ("z", "-y")),
]


@dataclass(frozen=True)
class Animal:
    """vertices [V, 3], faces [F, 3] (+y up, +z front, feet at y = 0); head [3] the head's centre; rump [3] the
    trunk's hindmost point on its axis (where the tail starts, tail or not); params the drawn proportions."""
    name: str
    family: str
    vertices: np.ndarray
    faces: np.ndarray
    head: np.ndarray
    rump: np.ndarray
    params: dict


def draw(family: str, rng: np.random.Generator) -> dict:
    """The proportions of one animal of ``family`` (lengths in body lengths: shoulder to hip = 1)."""
    u = rng.uniform
    if family == "cartoon":
        p = dict(girth=u(0.28, 0.42), legs=u(0.12, 0.4), neck=u(0.0, 0.18), neck_rise=u(60, 90),
                 head=u(0.3, 0.55), snout=u(0.0, 0.35), ears=rng.choice(["long", "round", "horns", "none"]),
                 tail=rng.choice(["raised", "bushy", "curled", "none"]), tail_length=u(0.6, 1.3))
    elif family == "realistic":
        p = dict(girth=u(0.2, 0.3), legs=u(0.45, 0.8), neck=u(0.25, 0.5), neck_rise=u(20, 55),
                 head=u(0.12, 0.18), snout=u(0.2, 0.4), ears=rng.choice(["long", "round", "none"]),
                 tail=rng.choice(["hanging"]), tail_length=u(0.3, 0.8))
    elif family == "long_legged":
        p = dict(girth=u(0.2, 0.28), legs=u(0.9, 1.6), neck=u(0.5, 1.3), neck_rise=u(40, 75),
                 head=u(0.1, 0.15), snout=u(0.2, 0.45), ears=rng.choice(["long", "horns", "none"]),
                 tail=rng.choice(["hanging", "raised"]), tail_length=u(0.25, 0.6))
    elif family == "low":
        p = dict(girth=u(0.14, 0.22), legs=u(0.08, 0.2), neck=u(0.05, 0.25), neck_rise=u(-10, 20),
                 head=u(0.1, 0.16), snout=u(0.3, 0.9), ears=rng.choice(["long", "none"]),
                 tail=rng.choice(["thick", "thick", "thin"]), tail_length=u(0.5, 1.4))
    else:
        raise ValueError(f"unknown family {family!r}; expected one of {', '.join(FAMILIES)}")
    # Which way and how much each leg joint bends: fractions of the leg's length.
    # Where the head sits along the body, beyond the neck's end (negative: back over the chest, a cartoon's).
    p["head_back"] = u(0.0, 0.4) if family == "cartoon" else 0.0
    p.update(elbow_back=u(0.05, 0.2), wrist_forward=u(0.0, 0.1), knee_forward=u(0.08, 0.25),
             hock_back=u(0.1, 0.3), chest=u(1.0, 1.3), leg_thickness=u(0.25, 0.45))
    return {k: (str(v) if isinstance(v, np.str_) else float(v)) for k, v in p.items()}


def build(p: dict, resolution: int = 80) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(vertices [V, 3], faces [F, 3], head centre [3], rump [3]) of the animal with proportions ``p``."""
    P = lambda x, y, z: np.array([x, y, z], dtype=float)  # noqa: E731
    g = p["girth"]                       # the trunk's half-height
    leg = p["legs"] + g                  # ground to the shoulder and hip joints (in the trunk's middle)
    y0 = leg
    front, back = 0.5, -0.5
    shapes = [
        _Ellipsoid(P(0, y0, 0.2), P(0.9 * g * p["chest"], g * p["chest"], 0.5)),      # chest
        _Ellipsoid(P(0, y0 + 0.05 * g, -0.3), P(0.85 * g, 0.95 * g, 0.42)),             # loins and rump
    ]
    rump = P(0, y0 + 0.05 * g, -0.72)
    leg_r = p["leg_thickness"] * g * (0.6 if p["legs"] > 0.7 else 1.0)
    for m in (1.0, -1.0):
        x = m * 0.55 * g
        for top_z, upper, lower in ((front, -p["elbow_back"], p["wrist_forward"]),
                                    (back, p["knee_forward"], -p["hock_back"])):
            top = P(x, y0, top_z)
            mid = P(x, 0.55 * leg, top_z + upper * leg)
            low = P(x, 0.22 * leg, top_z + (upper + lower) * leg)
            paw = P(x, 0.35 * leg_r, low[2] + 0.3 * leg_r)
            shapes += [_Cone(top, mid, 1.1 * leg_r, 0.8 * leg_r), _Cone(mid, low, 0.8 * leg_r, 0.6 * leg_r),
                       _Cone(low, paw, 0.6 * leg_r, 0.55 * leg_r),
                       _Ellipsoid(paw + P(0, 0, 0.4 * leg_r), P(0.7 * leg_r, 0.4 * leg_r, 1.0 * leg_r))]
    # The neck leaves the chest's front top and rises at neck_rise degrees; the head sits on its end.
    rise = np.radians(p["neck_rise"])
    neck_base = P(0, y0 + 0.4 * g, front + 0.1)
    neck_dir = P(0, np.sin(rise), np.cos(rise))
    skull = neck_base + p["neck"] * neck_dir + P(0, 0.6 * p["head"], 0.2 * p["head"] - p["head_back"])
    if p["neck"] > 0.02:
        shapes.append(_Cone(neck_base - 0.2 * neck_dir, skull, 0.7 * g, 0.6 * p["head"]))
    h = p["head"]
    head_dir = _unit([0, -0.25, 1])
    shapes.append(_Ellipsoid(skull, P(0.85 * h, 0.9 * h, h), _frame(head_dir, P(0, 1, 0))))
    if p["snout"] > 0:
        tip = skull + (h + p["snout"] * 1.0) * head_dir
        shapes.append(_Cone(skull + 0.3 * h * head_dir, tip, 0.55 * h, 0.3 * h))
    for m in (1.0, -1.0):
        base = skull + P(m * 0.5 * h, 0.7 * h, -0.1 * h)
        if p["ears"] == "long":
            shapes.append(_Cone(base, base + P(m * 0.25 * h, 1.1 * h, -0.3 * h), 0.22 * h, 0.08 * h))
        elif p["ears"] == "round":
            shapes.append(_Ellipsoid(base + P(m * 0.1 * h, 0.2 * h, 0), P(0.35, 0.35, 0.12) * h))
        elif p["ears"] == "horns":
            shapes.append(_Cone(base, base + P(m * 0.4 * h, 0.7 * h, -0.5 * h), 0.15 * h, 0.04 * h))
    t, tail = p["tail_length"], p["tail"]
    if tail == "hanging":
        bend = rump + P(0, -0.3 * t, -0.35 * t)
        shapes += [_Cone(rump, bend, 0.25 * g, 0.12 * g), _Cone(bend, bend + P(0, -0.5 * t, -0.2 * t), 0.12 * g,
                                                                0.07 * g)]
    elif tail == "thin":
        shapes.append(_Cone(rump, rump + P(0, -0.1 * t, -t), 0.25 * g, 0.06 * g))
    elif tail == "raised":
        bend = rump + P(0, 0.35 * t, -0.45 * t)
        shapes += [_Cone(rump, bend, 0.3 * g, 0.15 * g), _Cone(bend, bend + P(0, 0.45 * t, -0.1 * t), 0.15 * g,
                                                               0.08 * g)]
    elif tail == "bushy":
        end = rump + P(0, 0.6 * t, -0.5 * t)
        shapes += [_Cone(rump, rump + 0.3 * (end - rump), 0.25 * g, 0.2 * g),
                   _Ellipsoid((rump + end) / 2 + P(0, 0.1 * t, 0), P(0.35 * g, 0.45 * t, 0.9 * g),
                              _frame(_unit(P(0, 0.2, 1)), P(0, 1, 0)))]
    elif tail == "curled":
        a, b = rump + P(0, 0.3 * t, -0.3 * t), rump + P(0, 0.6 * t, -0.1 * t)
        shapes += [_Cone(rump, a, 0.3 * g, 0.2 * g), _Cone(a, b, 0.2 * g, 0.15 * g),
                   _Cone(b, b + P(0, 0.0, 0.2 * t), 0.15 * g, 0.1 * g)]
    elif tail == "thick":
        mid = rump + P(0, -0.3 * g, -0.5 * t)
        shapes += [_Cone(rump + P(0, 0, 0.2), mid, 0.85 * g, 0.45 * g),
                   _Cone(mid, mid + P(0, -0.4 * g, -0.5 * t), 0.45 * g, 0.08 * g)]
    vertices, faces = _mesh(shapes, blend=0.08 * g, resolution=resolution)
    # Feet at y = 0, as a file would have them.
    offset = P(0, -vertices[:, 1].min(), 0)
    return vertices + offset, faces, skull + offset, rump + offset


def family(name: str, count: int, seed: int, resolution: int = 80) -> list[Animal]:
    """``count`` animals of family ``name``, the same ones for the same seed."""
    rng = np.random.default_rng([seed, FAMILIES.index(name)])
    out = []
    for n in range(count):
        p = draw(name, rng)
        # A low animal is long for its height: a finer grid keeps its short legs apart from its belly.
        vertices, faces, head, rump = build(p, 2 * resolution if name == "low" else resolution)
        out.append(Animal(f"{name}_{n}", name, vertices, faces, head, rump, p))
    return out


def judge(rig, animal: Animal, turn, axes) -> str:
    """'right', 'reversed' (up right, head joint nearer the rump) or 'wrong up' for a rig of ``animal`` turned
    by ``turn``, which detection should have found in ``axes``."""
    if rig.info["up"] != axes[0]:
        return "wrong up"
    head = rig.joints[rig.names.index("head")]
    true_head, rump = turn(animal.head[None])[0], turn(animal.rump[None])[0]
    return "right" if np.linalg.norm(head - true_head) < np.linalg.norm(head - rump) else "reversed"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-family", type=int, default=6)
    parser.add_argument("--families", default=",".join(FAMILIES))
    parser.add_argument("--template", default="quadruped")
    parser.add_argument("--seed", type=int, default=26)
    parser.add_argument("--save", type=Path, help="write each animal as built here (OBJ), to look at")
    parser.add_argument("--explain", action="store_true", help="embedding gap and cues per animal (see above)")
    parser.add_argument("--corpus", type=Path, help="with --explain: also the corpus animals of this folder "
                                                    "(shared/data/train: those with a quadruped map)")
    args = parser.parse_args(argv)
    import autorig
    from autorig.exchange.obj import write_obj
    families = args.families.split(",")
    if any(f not in FAMILIES for f in families):
        print(f"quadruped_axes: families are {', '.join(FAMILIES)}", file=sys.stderr)
        return 2
    if args.explain:
        return explain(families, args.per_family, args.seed, args.template, args.corpus)
    counts: dict = {}
    for fam in families:
        for animal in family(fam, args.per_family, args.seed):
            if args.save:
                args.save.mkdir(parents=True, exist_ok=True)
                write_obj(animal.vertices, animal.faces, args.save / f"{animal.name}.obj")
            cells = []
            for turn_name, turn, axes in TURNS:
                start = time.perf_counter()
                try:
                    rig = autorig.rig((turn(animal.vertices), animal.faces), args.template, autorig.RigOptions())
                    verdict = judge(rig, animal, turn, axes)
                except Exception as e:    # a rig that fails is a result too
                    verdict = f"failed ({e})"
                counts.setdefault((fam, turn_name), []).append(verdict)
                cells.append(f"{turn_name}: {verdict} {time.perf_counter() - start:4.1f}s")
            shape = (f"head {animal.params['head']:.2f} neck {animal.params['neck']:.2f} legs "
                     f"{animal.params['legs']:.2f} tail {animal.params['tail']} ears {animal.params['ears']}")
            print(f"{animal.name:14s} {len(animal.faces):6d} faces  {shape:60s} | " + " | ".join(cells), flush=True)
    print(f"\n{'family':12s} " + " ".join(f"{t[0]:>18s}" for t in TURNS) + "   (right/reversed/other)")
    total = {"right": 0, "reversed": 0, "other": 0}
    for fam in families:
        row = []
        for turn_name, _, _ in TURNS:
            v = counts[(fam, turn_name)]
            right, rev = v.count("right"), v.count("reversed")
            total["right"] += right
            total["reversed"] += rev
            total["other"] += len(v) - right - rev
            row.append(f"{right:>10d}/{rev}/{len(v) - right - rev}")
        print(f"{fam:12s} " + " ".join(f"{c:>18s}" for c in row))
    print(f"all: right {total['right']}, reversed {total['reversed']}, other {total['other']} of "
          f"{sum(total.values())} rigs")
    return 0


def explain(families: list[str], per_family: int, seed: int, template_name: str, corpus: Path | None) -> int:
    """Print the embedding's gap and the cues of every animal (see the module docstring)."""
    from autorig.template import load_template
    template = load_template(template_name)
    print(f"{'animal':24s} {'back - own':>10s} {'outline':>8s} {'bulk':>6s} {'share':>6s} {'crest':>6s} "
          f"{'toes':>6s} {'2 w.cues':>8s} {'sum':>7s}")
    bound = np.inf if template.head_gap is None else template.head_gap
    rows = [(a.name, a.vertices, a.faces) for fam in families for a in family(fam, per_family, seed)]
    if corpus is not None:
        rows += list(_corpus_animals(corpus))
    for name, vertices, faces in rows:
        gap, outline, bulk, prior, share, crest, toes = ends_explained(vertices, faces, template)
        print(f"{name:24s} {gap:10.2f} {outline:8.2f} {bulk:6.2f} {share:6.2f} {crest:6.2f} {toes:6.2f} {prior:8.2f} "
              f"{float(np.clip(gap, -bound, bound)) + prior:7.2f}", flush=True)
    return 0


def ends_explained(vertices: np.ndarray, faces: np.ndarray, template) -> tuple[float, ...]:
    """(embedding penalty facing -z minus facing +z, outline cue, bulk cue, the weighted cues' difference
    between the two frames, weight share, crest, feet) of a +y up, +z front animal (vertices [V, 3], faces [F, 3])."""
    from autorig.embed.ends import end_bulk_cue, toes_cue, weight_share_cue
    from autorig.input.mesh import prepare
    from autorig.embed.orient import (DECISION_EXPANSIONS, _embedding_cost, _problem, crest_cue, head_tail_cue,
                                      weighted_cues)
    from autorig.pipeline import discretize
    prepared = prepare(vertices, faces, "y", "z")
    _, graph = discretize(prepared)
    back = prepared.frame_change("y", "-z")
    own_cost = _embedding_cost(_problem(graph, template), DECISION_EXPANSIONS)[0]
    back_cost = _embedding_cost(_problem(graph.moved(back.apply(graph.centers), back.scale), template),
                                DECISION_EXPANSIONS)[0]
    V, toes = prepared.work_vertices, toes_cue(graph, prepared.work_vertices, prepared.work_faces)
    prior = 2 * weighted_cues(template, graph, V, toes)    # the cues negate when the shape is turned round
    return (back_cost - own_cost, head_tail_cue(V), end_bulk_cue(graph, V), prior, weight_share_cue(graph, V),
            crest_cue(V), toes)


def _corpus_animals(train: Path):
    """(name, vertices [V, 3], faces [F, 3]) of the corpus animals, +y up and +z front as shipped."""
    import json

    from autorig.input.mesh import load_mesh
    for folder in sorted(p for p in train.iterdir() if (p / "joints.json").is_file()):
        if "quadruped_map" in json.loads((folder / "joints.json").read_text()):
            yield (folder.name, *load_mesh(folder / "mesh.obj"))


if __name__ == "__main__":
    sys.exit(main())
