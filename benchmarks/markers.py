"""Markers (``autorig MESH --markers FILE``) on every character with an artist's rig, and on rigs made wrong on
purpose.

    python benchmarks/markers.py [--shared ../shared] [--corpus ../corpus] [--maps data/maps] [--only NAME,...]
                                 [--skip-wrong] [--json FILE] [--measure]

The characters: ``shared/data/rigged`` and ``shared/data/more`` (with the maps of ``data/maps/``) and every corpus
folder (``../corpus``) with a biped or quadruped map; bipeds rigged with the biped template, four-legged animals
with the quadruped, their axes detected (as a user rigs them). Each is rigged twice: without markers, and with the
artist's joints given as the template's marker set (``autorig.markers``: a wrist at the artist's wrist, the chin
at the artist's head joint less the chin's offset, ...; a leg without a paw joint is marked at its lowest joint,
by that joint's name). Printed per source (shared, more, and each corpus source):

- marked: how far each marked joint lies from its marker, on the axes the marker holds (mean, worst), in % of the
  height; the issue asks for every one within 1 %;
- others: the other template joints' error against the artist's (``shared/tools/score.py``'s: % of the height),
  mean and worst, without and with markers;
- top-1: the skin weights' top-1 agreement with the artist's (score.py's), without and with markers.

Wrong on purpose (``--skip-wrong`` leaves it out): each four-legged corpus animal and the shared Fox rigged with
its axes given wrong (up given as its front axis; front given reversed) and turned to face -z with the axes
detected, each without and with markers; the structure (``benchmarks/animals.py``: each paw and the head nearer
its own artist's joint than any other's, within 15 % of the largest extent) right or wrong, or the error line.

``--measure`` prints the markers' offsets measured on the artists' rigs (``autorig.markers``): the hips' height
above the crotch and the head joint's above the chin (bipeds), the neck's base ahead of the front shoulders
(four-legged animals), in % of the height, and stops.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LOWEST = {"front": ("paw", "wrist", "elbow"), "back": ("paw", "ankle", "knee")}


def characters(shared: Path, corpus: Path, maps: Path, only: set | None) -> list[dict]:
    """[{name, source, kind, gt}]: every rigged character with a biped or quadruped map, ``gt`` as score.py's
    ``load_gt`` gives it."""
    import score
    folders = [(p, "shared") for p in sorted((shared / "data" / "rigged").glob("*/joints.json"))]
    folders += [(p, None) for p in sorted(corpus.glob("*/joints.json"))] if corpus.is_dir() else []
    out = []
    for joints, source in folders:
        name = joints.parent.name
        if only and name not in only:
            continue
        gt = score.load_gt(str(joints.parent))
        if gt["kind"] is None:
            continue
        out.append({"name": name, "source": source or name.split("_")[0], "kind": gt["kind"], "gt": gt})
    for map_file in sorted(maps.glob("*.json")):
        meta = json.loads(map_file.read_text())
        glb = shared / "data" / "more" / map_file.stem / "model.glb"
        if not glb.is_file() or (only and map_file.stem not in only):
            continue
        out.append({"name": map_file.stem, "source": "more", "kind": meta["category"],
                    "gt": _gt_of_glb(glb, map_file, meta)})
    return out


def _gt_of_glb(glb: Path, map_file: Path, meta: dict) -> dict:
    """A rigged glTF with its template map, as score.py's ``load_gt`` would give it."""
    from autorig.learn.examples import read_mapped_gltf
    from autorig.template import load_template
    kind = meta["category"]
    example = read_mapped_gltf(glb, map_file, load_template("biped" if kind == "biped" else "quadruped"))
    axes = {k: _vector(spec) for k, spec in (("up", example.up), ("front", example.front))}
    axes["left"] = np.cross(axes["up"], axes["front"])
    V = np.asarray(example.vertices, float)
    return {"name": map_file.stem, "V": V, "F": np.asarray(example.faces), "joint_names": list(example.names),
            "joint_parents": np.asarray(example.parents), "joint_pos": np.asarray(example.positions, float),
            "kind": kind, "map": {k: example.names[i] for k, i in example.key_of.items()},
            "W": np.asarray(example.weights, float), "height": float(np.ptp(V @ axes["up"])), **axes,
            "meta": meta}


def _vector(spec: str) -> np.ndarray:
    out = np.zeros(3)
    out["xyz".index(spec[-1])] = -1.0 if spec.startswith("-") else 1.0
    return out


def artist_markers(gt: dict, template) -> dict[str, list[float]]:
    """The template's marker set at the artist's joints (each marker's offset taken off, in the GT's axes); a
    paw the artist has no joint for is marked at its leg's lowest joint, by that joint's name."""
    import score
    from autorig.markers import marker_names, marker_of
    truth = score.gt_template_joints(gt)
    frame = np.array([gt["left"], gt["up"], gt["front"]])     # rows: canonical x, y, z in the GT's coordinates
    out = {}
    for name in marker_names(template):
        marker = marker_of(name)
        joint = marker.joint
        if joint not in truth and joint.endswith("_paw"):
            leg = joint[:-len("_paw")]
            joint = next((f"{leg}_{j}" for j in LOWEST[leg.split("_")[0]] if f"{leg}_{j}" in truth), None)
            name = joint
        if joint is None or joint not in truth:
            continue
        out[name] = (truth[joint] - (np.asarray(marker.offset) * gt["height"]) @ frame).tolist()
    return out


def held_errors(gt: dict, rig_joints: dict, markers: dict) -> dict[str, float]:
    """{marker: % of the height} how far each marked joint lies from its artist's joint on the axes it holds."""
    import score
    from autorig.markers import marker_of
    truth = score.gt_template_joints(gt)
    frame = np.array([gt["left"], gt["up"], gt["front"]])
    out = {}
    for name in markers:
        marker = marker_of(name)
        diff = frame @ (rig_joints[marker.joint] - truth[marker.joint])
        out[name] = 100 * float(np.linalg.norm(diff[list(marker.held)])) / gt["height"]
    return out


def rig_scores(character: dict, template: str, markers: dict | None, options: dict | None = None) -> dict:
    """One rig of a character, scored as score.py scores it; {"error": line} when it fails."""
    import autorig
    import score
    from autorig.errors import AutorigError
    from autorig.markers import marker_of
    gt = character["gt"]
    start = time.perf_counter()
    try:
        rig = autorig.rig((gt["V"], gt["F"]), template, autorig.RigOptions(markers=markers, **(options or {})))
    except AutorigError as e:
        return {"error": str(e)}
    seconds = time.perf_counter() - start
    joints = dict(zip(rig.names, np.asarray(rig.joints, float)))
    errors = score.joint_errors(gt, joints, character["kind"])["per_key"]
    weights = score.weight_scores(gt, rig.weights, rig.names, rig.parents, rig.joints, pred_vertices=rig.vertices,
                                  kind=character["kind"])
    return {"errors": {k: 100 * v for k, v in errors.items()}, "top1": weights["top1_pct"],
            "seconds": seconds, "axes": [rig.info["up"], rig.info["front"]],
            "held": held_errors(gt, joints, markers) if markers else {},
            "marked": sorted({marker_of(n).joint for n in markers}) if markers else []}


def compare(characters_: list[dict], say) -> list[dict]:
    rows = []
    for c in characters_:
        template = "biped" if c["kind"] == "biped" else "quadruped"
        markers = artist_markers(c["gt"], template)
        plain = rig_scores(c, template, None)
        marked = rig_scores(c, template, markers)
        row = {"name": c["name"], "source": c["source"], "template": template, "plain": plain, "markers": marked,
               "marker_set": sorted(markers)}
        rows.append(row)
        say(_line(row))
    return rows


def _others(result: dict, marked: list[str]) -> list[float]:
    return [v for k, v in result["errors"].items() if k not in marked]


def _line(row: dict) -> str:
    p, m = row["plain"], row["markers"]
    head = f"{row['name'][:40]:40s} {row['source']:12s}"
    if "error" in p or "error" in m:
        return f"{head} FAILED {p.get('error', '')} | {m.get('error', '')}"
    held = list(m["held"].values())
    po, mo = _others(p, m["marked"]), _others(m, m["marked"])
    return (f"{head} marked {np.mean(held):5.2f} {max(held):5.2f} | others {np.mean(po):5.2f} {max(po):5.2f} -> "
            f"{np.mean(mo):5.2f} {max(mo):5.2f} | top-1 {p['top1']:5.1f} -> {m['top1']:5.1f} | "
            f"{p['seconds']:4.1f} s -> {m['seconds']:4.1f} s")


def summary(rows: list[dict]) -> list[str]:
    out = [f"{'source':12s} {'n':>3s} {'marked mean':>11s} {'worst':>6s} {'<=1%':>6s} | {'others mean':>11s} "
           f"{'worst':>6s} -> {'mean':>5s} {'worst':>6s} | {'top-1':>6s} -> {'top-1':>6s} | failed"]
    for source in sorted({r["source"] for r in rows}) + ["all"]:
        group = [r for r in rows if source in ("all", r["source"])]
        ok = [r for r in group if "error" not in r["plain"] and "error" not in r["markers"]]
        if not ok:
            out.append(f"{source:12s} {len(group):3d} all failed")
            continue
        held = [v for r in ok for v in r["markers"]["held"].values()]
        plain_means = [np.mean(_others(r["plain"], r["markers"]["marked"])) for r in ok]
        marked_means = [np.mean(_others(r["markers"], r["markers"]["marked"])) for r in ok]
        plain_worst = max(max(_others(r["plain"], r["markers"]["marked"])) for r in ok)
        marked_worst = max(max(_others(r["markers"], r["markers"]["marked"])) for r in ok)
        within = sum(v <= 1.0 for v in held)
        out.append(f"{source:12s} {len(group):3d} {np.mean(held):11.2f} {max(held):6.2f} {within:3d}/{len(held):<3d}| "
                   f"{np.mean(plain_means):11.2f} {plain_worst:6.2f} -> {np.mean(marked_means):5.2f} "
                   f"{marked_worst:6.2f} | {np.mean([r['plain']['top1'] for r in ok]):6.1f} -> "
                   f"{np.mean([r['markers']['top1'] for r in ok]):6.1f} | {len(group) - len(ok)}")
    return out


# Axes given wrong on purpose, and a turn: (label, mesh move, truth move, options)
def wrong_cases(gt: dict) -> list[tuple[str, object, dict]]:
    up, front = _spec(gt["up"]), _spec(gt["front"])
    flipped = front[1:] if front.startswith("-") else "-" + front
    return [("up given as front", lambda v: v, {"up": front.lstrip("+"), "front": "auto"}),
            ("front given reversed", lambda v: v, {"up": up.lstrip("+"), "front": flipped.lstrip("+")}),
            ("turned, detected", lambda v: v - 2 * (v @ gt["left"])[..., None] * gt["left"]
             - 2 * (v @ gt["front"])[..., None] * gt["front"], {})]   # half a turn about up


def _spec(vector) -> str:
    axis = int(np.argmax(np.abs(vector)))
    return ("-" if vector[axis] < 0 else "") + "xyz"[axis]


def wrong_on_purpose(characters_: list[dict], say) -> list[dict]:
    import autorig
    import animals
    from autorig.errors import AutorigError
    rows = []
    for c in characters_:
        if c["kind"] != "quadruped" or c["source"] == "more":
            continue
        gt = c["gt"]
        markers = artist_markers(gt, "quadruped")
        import score
        truth = score.gt_template_joints(gt)
        extent = float(max(np.ptp(gt["V"] @ gt["up"]), np.ptp(gt["V"] @ gt["front"])))
        for label, move, options in wrong_cases(gt):
            row = {"name": c["name"], "case": label}
            for with_markers in (False, True):
                given = {k: move(np.asarray(v, float)).tolist() for k, v in markers.items()} if with_markers else None
                try:
                    rig = autorig.rig((move(gt["V"]), gt["F"]), "quadruped",
                                      autorig.RigOptions(markers=given, **options))
                except AutorigError as e:
                    row["markers" if with_markers else "plain"] = {"error": str(e)}
                    continue
                result = animals.score(dict(zip(rig.names, np.asarray(rig.joints, float))),
                                       {k: move(v) for k, v in truth.items()}, extent)
                row["markers" if with_markers else "plain"] = {
                    "structure": result["structure"], "axes": [rig.info["up"], rig.info["front"]],
                    "confidence": rig.info["confidence"]}
            rows.append(row)
            say(f"{c['name'][:30]:30s} {label:22s} without: {_verdict(row['plain'])} | with markers: "
                f"{_verdict(row['markers'])}")
    return rows


def _verdict(result: dict) -> str:
    if "error" in result:
        return f"error: {result['error'][:90]}"
    return (f"{'right' if result['structure'] else 'WRONG'} (axes {','.join(result['axes'])}, confidence "
            f"{result['confidence']:.2f})")


def wrong_summary(rows: list[dict]) -> list[str]:
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        group = [r for r in rows if r["case"] == case]
        counts = []
        for side in ("plain", "markers"):
            right = sum(r[side].get("structure", False) for r in group)
            errors = sum("error" in r[side] for r in group)
            counts.append(f"{right}/{len(group)} right" + (f", {errors} refused with an error line" if errors else ""))
        out.append(f"{case:22s} without markers: {counts[0]:38s} with markers: {counts[1]}")
    return out


def measure(characters_: list[dict]) -> list[str]:
    """The markers' offsets on the artists' rigs (see the module docstring), in % of the height."""
    import igl
    import score
    groin, chin, withers = [], [], []
    for c in characters_:
        gt = c["gt"]
        truth = score.gt_template_joints(gt)
        H, up, front, left = gt["height"], gt["up"], gt["front"], gt["left"]
        V, F = np.asarray(gt["V"], float), np.asarray(gt["F"], np.int64)
        if c["kind"] == "biped" and "hips" in truth:
            steps = truth["hips"][None] - np.linspace(0, 0.3, 301)[:, None] * H * up[None]
            inside = np.abs(igl.fast_winding_number(V, F, steps)) >= 0.5
            if inside[0] and not inside.all():
                groin.append(100 * float(np.linspace(0, 0.3, 301)[np.argmin(inside)]))
            if "head" in truth and "neck" in truth:
                mid = np.abs((V - truth["head"]) @ left) < 0.01 * H
                y, z = V[mid] @ up, V[mid] @ front
                grid = np.arange(truth["neck"] @ up, truth["head"] @ up + 0.06 * H, 0.004 * H)
                profile = np.array([z[np.abs(y - g) < 0.006 * H].max(initial=-np.inf) for g in grid])
                with np.errstate(invalid="ignore"):
                    jump = profile[2:] - profile[:-2]
                if np.isfinite(jump).any():
                    chin.append(100 * float(truth["head"] @ up - grid[1 + int(np.nanargmax(
                        np.where(np.isfinite(jump), jump, -np.inf)))]) / H)
        elif c["kind"] == "quadruped" and {"neck", "front_left_shoulder", "front_right_shoulder"} <= set(truth):
            shoulders = (truth["front_left_shoulder"] + truth["front_right_shoulder"]) / 2
            withers.append(100 * float((truth["neck"] - shoulders) @ front) / H)
    return [f"{label}: median {np.median(v):.1f} %, mean {np.mean(v):.1f} %, quartiles {np.percentile(v, 25):.1f} - "
            f"{np.percentile(v, 75):.1f} % of the height ({len(v)} rigs)"
            for label, v in (("groin -> hips (up)", groin), ("chin -> head (up)", chin),
                             ("withers -> neck (front)", withers)) if v]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "corpus")
    parser.add_argument("--maps", type=Path, default=ROOT / "data" / "maps")
    parser.add_argument("--only", help="only these characters (comma-separated folder names)")
    parser.add_argument("--skip-wrong", action="store_true", help="leave out the rigs made wrong on purpose")
    parser.add_argument("--json", type=Path, help="write every row here")
    parser.add_argument("--measure", action="store_true", help="print the markers' offsets on the artists' rigs")
    args = parser.parse_args(argv)
    if not (args.shared / "tools" / "score.py").is_file():
        print(f"error: no scorer at {args.shared / 'tools' / 'score.py'}", file=sys.stderr)
        return 1
    sys.path.insert(0, str(args.shared / "tools"))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    found = characters(args.shared, args.corpus, args.maps, set(args.only.split(",")) if args.only else None)
    if args.measure:
        print("\n".join(measure(found)))
        return 0
    say = lambda s: print(s, flush=True)   # noqa: E731
    say(f"{len(found)} characters")
    rows = compare(found, say)
    say("\n".join([""] + summary(rows)))
    wrong = [] if args.skip_wrong else wrong_on_purpose(found, say)
    if wrong:
        say("\n".join([""] + wrong_summary(wrong)))
    if args.json:
        from autorig.exchange import write_file_atomic
        write_file_atomic(args.json, json.dumps({"rows": rows, "wrong": wrong}, indent=1).encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
