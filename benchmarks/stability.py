"""Stability: the same character gets the same rig (issue 37).

    python benchmarks/stability.py [--shared ../shared] [--corpus ../corpus] [--only NAME,...] [--seeds 3]
                                   [--variants noise,order,corners,units,turn,same] [--detected] [--json FILE]

Each character is rigged once as it is and once per variant of its mesh that does not change the character:
- ``noise``: every coordinate moved by uniform noise of at most 1e-6 x the height (what re-exporting does to the
  floats), one rig per seed;
- ``order``: the vertices in a seeded random order (the faces renumbered), ``corners``: each triangle's corners
  turned one place;
- ``units``: x0.01 and x100;
- ``turn``: the mesh turned 90 degrees about its up axis, with the axes given accordingly;
- ``same``: the very same arrays again (the same bytes must give the same rig, to the bit).
Every variant's joints are taken back into the original's frame and compared with the original's by name: the
largest move of any joint (tips included) as a percentage of the height, and which joint. The characters: the
shared rigged characters and meshes whose axes are known, the bipeds and four-legged animals of
``shared/data/more`` (glTF, each with the map under ``data/maps`` that names its kind), every biped and
four-legged corpus character
(``shared/data/train``, and ``CORPUS``'s MakeHuman and Lugaru bodies), each with the template its category
calls for and its axes given (``--detected``: axes detected in every rig, turned variants included).
Rigs run in this process (no start-up per rig); one character takes 10-30 s with the default variants.

``--posed "arms bent,idle"``: instead, every biped example the shipped biped learns from re-posed as
``benchmarks/poses.py`` poses it (through its artist's weights; any of ``poses.POSES``), each pose a character
of its own (``NAME (pose)``), with its axes given. ``--animal-poses "walk;head low;walk, head low"``: the same
for the 31 four-legged animals of ``benchmarks/animals.py``, re-posed as ``benchmarks/animal_poses.py`` poses them,
rigged with the shipped quadruped (``--only`` matches the animal's name).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# file under shared/data, template, up, front: the shared characters whose axes are known.
SHARED = [
    ("meshes/armadillo.obj", "biped", "y", "z"), ("meshes/homer.obj", "biped", "y", "z"),
    ("meshes/ogre.obj", "biped", "y", "z"), ("meshes/beast.obj", "biped", "y", "z"),
    ("meshes/cheburashka.obj", "biped", "y", "z"),
    ("meshes/cow.obj", "quadruped", "y", "x"), ("meshes/spot.obj", "quadruped", "y", "-z"),
    ("meshes/horse.obj", "horse", "z", "y"),
    ("rigged/CesiumMan/mesh.obj", "biped", "y", "x"), ("rigged/RiggedFigure/mesh.obj", "biped", "y", "z"),
    ("rigged/Fox/mesh.obj", "quadruped", "y", "z"),
]
TEMPLATE_OF = {"biped": "biped", "quadruped": "quadruped"}
AXES = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}
NOISE = 1e-6


def characters(shared: Path, corpus: Path | None):
    """(name, obj path, template, up, front) of every character measured."""
    for rel, template, up, front in SHARED:
        if (shared / "data" / rel).is_file():
            yield Path(rel).parent.name if rel.startswith("rigged/") else Path(rel).stem, \
                shared / "data" / rel, template, up, front
    # shared/data/more's characters as glTF, with the template their map (data/maps) names by category
    for map_file in sorted((ROOT / "data" / "maps").glob("*.json")):
        meta = json.loads(map_file.read_text())
        glb = shared / "data" / "more" / map_file.stem / "model.glb"
        template = TEMPLATE_OF.get(meta.get("category", ""))
        if template is not None and glb.is_file():
            yield map_file.stem, glb, template, meta.get("up_axis", "+y").lstrip("+"), \
                meta.get("front_axis", "+z").lstrip("+")
    folders = sorted((shared / "data" / "train").glob("*/joints.json"))
    if corpus is not None and corpus.is_dir():
        folders += sorted(corpus.glob("*/joints.json"))
    for meta_path in folders:
        meta = json.loads(meta_path.read_text())
        template = TEMPLATE_OF.get(meta.get("category", ""))
        if template is None or not (meta_path.parent / "mesh.obj").is_file():
            continue
        yield meta_path.parent.name, meta_path.parent / "mesh.obj", template, \
            meta.get("up_axis", "+y").lstrip("+"), meta.get("front_axis", "+z").lstrip("+")


def axis_vector(name: str) -> np.ndarray:
    return AXES[name[-1]] * (-1.0 if name.startswith("-") else 1.0)


def axis_name(vector: np.ndarray) -> str:
    i = int(np.argmax(np.abs(vector)))
    return ("-" if vector[i] < 0 else "") + "xyz"[i]


def turn_about(up: str) -> np.ndarray:
    """The rotation by 90 degrees about the (signed) axis ``up``."""
    u = axis_vector(up)
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + k + k @ k    # Rodrigues at 90 degrees: sin = 1, 1 - cos = 1


def variants(vertices, faces, up, front, height, names, seeds):
    """(variant name, vertices, faces, up, front, back) for each variant: ``back`` takes its joints into the
    original's frame."""
    same = lambda j: j    # noqa: E731
    if "same" in names:
        yield "same", vertices.copy(), faces.copy(), up, front, same
    if "noise" in names:
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            yield f"noise{seed}", vertices + rng.uniform(-NOISE, NOISE, vertices.shape) * height, faces, up, \
                front, same
    if "order" in names:
        order = np.random.default_rng(100).permutation(len(vertices))
        where = np.empty_like(order)
        where[order] = np.arange(len(order))
        yield "order", vertices[order], where[faces], up, front, same
    if "corners" in names:
        yield "corners", vertices, np.roll(faces, 1, axis=1), up, front, same
    if "units" in names:
        for factor in (0.01, 100.0):
            yield f"x{factor:g}", vertices * factor, faces, up, front, (lambda j, f=factor: j / f)
    if "turn" in names and up != "auto":
        turn = turn_about(up)
        yield "turn", vertices @ turn.T, faces, up, axis_name(turn @ axis_vector(front)) if front != "auto" \
            else "auto", (lambda j, t=turn: j @ t)


def measure(name, path, template, up, front, args):
    import autorig
    from autorig.pipeline import RigOptions
    from autorig.input.mesh import load_mesh

    vertices, faces = load_mesh(path, None)
    if args.detected:
        up_given, front_given = "auto", "auto"
    else:
        up_given, front_given = up, front
    height = float(np.ptp(vertices @ axis_vector(up)))
    base = autorig.rig((vertices, faces), template, RigOptions(up=up_given, front=front_given))
    joints = dict(zip(base.names, base.joints))
    rows = []
    for variant, v, f, vup, vfront, back in variants(vertices, faces, up_given, front_given, height,
                                                     args.variants, args.seeds):
        try:
            other = autorig.rig((v, f), template, RigOptions(up=vup, front=vfront))
        except Exception as error:    # noqa: BLE001 - a variant that does not rig is a result too
            rows.append((variant, float("inf"), f"failed: {error}", float("inf"), "-"))
            continue
        moved = back(np.asarray(other.joints))
        moves = {n: float(np.linalg.norm(p - joints[n])) / height * 100 for n, p in zip(other.names, moved)
                 if n in joints}
        worst = max(moves, key=moves.get)
        inner = [n for n in moves if not n.endswith("_end")]
        worst_inner = max(inner, key=moves.get) if inner else worst
        if variant == "same" and not np.array_equal(np.asarray(other.joints), np.asarray(base.joints)):
            worst += " (not bit-identical)"
        rows.append((variant, moves[worst], worst, moves[worst_inner], worst_inner))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--only", help="comma-separated character names (or parts of names)")
    parser.add_argument("--skip-corpus", action="store_true", help="the shared characters only")
    parser.add_argument("--seeds", type=int, default=3, help="noise seeds (default: %(default)s)")
    parser.add_argument("--variants", default="same,noise,order,corners,units,turn",
                        type=lambda s: set(s.split(",")))
    parser.add_argument("--detected", action="store_true", help="axes detected in every rig")
    parser.add_argument("--limit", type=float, default=0.5, help="largest move allowed, %% of the height")
    parser.add_argument("--json", type=Path, help="write every row here")
    parser.add_argument("--posed", type=lambda s: [p.strip() for p in s.split(",") if p.strip()],
                        help="comma-separated poses of benchmarks/poses.py: the bipeds re-posed, not at rest")
    parser.add_argument("--animal-poses", type=lambda s: [p.strip() for p in s.split(";") if p.strip()],
                        help='semicolon-separated poses of benchmarks/animal_poses.py ("walk;head low;walk, head '
                             'low"): the four-legged animals of benchmarks/animals.py re-posed, not at rest')
    args = parser.parse_args(argv)

    wanted = args.only.split(",") if args.only else None
    if args.posed or args.animal_poses:
        import tempfile
        with tempfile.TemporaryDirectory() as scratch:
            return run(args, posed_animals(args.shared, args.corpus, args.animal_poses, wanted, Path(scratch))
                       if args.animal_poses else
                       posed_characters(args.shared, args.corpus, args.posed, wanted, Path(scratch)))
    found = [c for c in characters(args.shared, args.corpus)
             if (wanted is None or any(w in c[0] for w in wanted))
             and not (args.skip_corpus and not any(str(c[1]).startswith(str(args.shared / "data" / d))
                                                   for d in ("meshes", "rigged", "more")))]
    return run(args, found)


def posed_characters(shared: Path, corpus: Path, poses: list[str], wanted, out: Path) -> list:
    """(name, obj path, "biped", up, front) of every biped example re-posed in each of ``poses``, written
    under ``out``."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from poses import POSES, characters as biped_examples, write_posed
    unknown = [p for p in poses if p not in POSES]
    if unknown:
        raise SystemExit(f"unknown poses {unknown}: of {', '.join(POSES)}")
    found = []
    for folder in biped_examples(shared, corpus, True):
        for pose in poses:
            name = f"{folder.name} ({pose})"
            if wanted is not None and not any(w in name for w in wanted):
                continue
            posed = write_posed(folder, pose, out / f"{folder.name}_{pose.replace(' ', '_')}")
            meta = json.loads((posed / "joints.json").read_text())
            found.append((name, posed / "mesh.obj", "biped", meta.get("up_axis", "+y").lstrip("+"),
                          meta.get("front_axis", "+z").lstrip("+")))
    return found


def posed_animals(shared: Path, corpus: Path, poses: list[str], wanted, out: Path) -> list:
    """(name, obj path, "quadruped", up, front) of every four-legged animal ``benchmarks/animals.py`` rigs,
    re-posed as ``benchmarks/animal_poses.py`` poses it in each of ``poses`` (through its artist's weights), written
    under ``out`` as OBJ."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import animal_poses
    import animals
    from autorig.template import load_template
    unknown = [p for p in poses if p not in animal_poses.POSES]
    if unknown:
        raise SystemExit(f"unknown animal poses {unknown}: of {'; '.join(animal_poses.POSES)}")
    found = []
    for animal in animals.gather(shared, corpus, ROOT / "data" / "maps",
                                 load_template(animals.HANDSET / "quadruped.json")):
        for pose in poses:
            name = f"{animal.name} ({pose})"
            if wanted is not None and not any(w in name for w in wanted):
                continue
            example = animals.posed_animal(animal, pose).example
            path = out / f"{animal.name}_{pose.replace(' ', '_').replace(',', '')}.obj"
            # written by hand, each float's repr: read back, the mesh is the one posed to the bit (trimesh's
            # export rounds it, and a rounded copy would be one more noise variant)
            vertices, faces = np.asarray(example.vertices, float), np.asarray(example.faces)
            path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
                            + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces.tolist()))
            found.append((name, path, "quadruped", example.up, example.front))
    return found


def run(args, found) -> int:
    """Measure each of ``found`` (name, path, template, up, front), print the table, write ``--json``."""
    table, over = {}, []
    print(f"{'character':40s} {'template':9s} {'worst move % (joint, variant)':s}")
    for name, path, template, up, front in found:
        start = time.perf_counter()
        try:
            rows = measure(name, path, template, up, front, args)
        except Exception as error:    # noqa: BLE001
            print(f"{name:40s} {template:9s} failed: {error}")
            over.append(name)
            continue
        table[name] = [{"variant": v, "move": m, "joint": j, "move_inner": mi, "joint_inner": ji}
                       for v, m, j, mi, ji in rows]
        variant, move, joint = max(rows, key=lambda r: r[1])[:3]
        inner_variant, inner_move, inner_joint = max(((r[0], r[3], r[4]) for r in rows), key=lambda r: r[1])
        if move > args.limit:
            over.append(name)
        cells = "  ".join(f"{v}:{m:.2f}" for v, m, *_ in rows)
        print(f"{name:32s} {template:9s} {move:6.2f} ({joint}, {variant}); not a tip {inner_move:.2f} ({inner_joint}, "
              f"{inner_variant})  [{cells}]  {time.perf_counter() - start:.0f}s", flush=True)
    print(f"\n{len(found) - len(over)} of {len(found)} characters move no joint more than {args.limit} % of the height "
          f"under any variant" + (f"; over it: {', '.join(over)}" if over else ""))
    if args.json:
        args.json.write_text(json.dumps(table, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
