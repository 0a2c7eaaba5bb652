"""Robustness on real and broken input: every shared mesh with automatic orientation, scale independence,
and the answer to each kind of bad input.

    python benchmarks/robustness.py [--shared ../shared]

1. Every mesh of ../shared/data/meshes and ../shared/data/rigged/*/mesh.obj, rigged through the CLI with
   --up auto --front auto and the template its category calls for (MANIFEST.md): detected axes against the
   known ones, confidence, success, and vertices left without weight (must be 0).
2. The project's mannequin at x0.001, x1 and x1000: joint positions divided by the scale must agree.
3. Bad input, each through the CLI: the one error line and the exit code; no output file may appear.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# file, template, known up, known front ("?" where the MANIFEST gives none)
SHARED_MESHES = [
    ("meshes/armadillo.obj", "biped", "y", "z"), ("meshes/homer.obj", "biped", "y", "z"),
    ("meshes/ogre.obj", "biped", "y", "z"), ("meshes/beast.obj", "biped", "y", "z"),
    ("meshes/cheburashka.obj", "biped", "y", "z"), ("meshes/sydney.obj", "biped", "y", "?"),
    ("meshes/woody.obj", "biped", "y", "z"), ("meshes/cow.obj", "quadruped", "y", "x"),
    ("meshes/spot.obj", "quadruped", "y", "-z"), ("meshes/horse.obj", "horse", "z", "y"),
    ("meshes/alligator.obj", "quadruped", "y", "?"), ("meshes/octopus_low.obj", "biped", "y", "?"),
    ("meshes/spider.obj", "biped", "y", "?"),
    ("rigged/CesiumMan/mesh.obj", "biped", "y", "x"), ("rigged/RiggedFigure/mesh.obj", "biped", "y", "z"),
    ("rigged/Fox/mesh.obj", "quadruped", "y", "z"), ("rigged/RiggedSimple/mesh.obj", "biped", "y", "?"),
    ("rigged/huesitos/mesh.obj", "biped", "y", "?"), ("rigged/animation_with_skeleton/mesh.obj", "biped", "x", "?"),
]


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "autorig.cli", *args], capture_output=True, text=True)


def shared_table(shared: Path, tmp: Path) -> None:
    print(f"{'mesh':36s} {'template':9s} {'detected':10s} {'known':7s} {'axes':5s} {'conf':>5s} "
          f"{'result':8s} {'unweighted':>10s}")
    for rel, template, up, front in SHARED_MESHES:
        path = shared / "data" / rel
        if not path.is_file():
            continue
        out = tmp / "out.json"
        out.unlink(missing_ok=True)
        run = cli(str(path), "--template", template, "-o", str(out))
        if run.returncode == 0:
            data = json.loads(out.read_text())
            info = data["info"]
            rows = data["weights"]["rows"]
            unweighted = sum(1 for _, w in rows if not w or sum(w) <= 0)
            detected = f"{info['up']}/{info['front']}"
            ok = info["up"].lstrip("+") == up and (front == "?" or info["front"].lstrip("+") == front)
            print(f"{rel:36s} {template:9s} {detected:10s} {up + '/' + front:7s} {'ok' if ok else 'WRONG':5s} "
                  f"{info['confidence']:5.2f} {'rigged':8s} {unweighted:10d}")
        else:
            message = run.stderr.strip().splitlines()[-1] if run.stderr.strip() else ""
            print(f"{rel:36s} {template:9s} {'-':10s} {up + '/' + front:7s} {'-':5s} {'-':>5s} "
                  f"{'exit ' + str(run.returncode):8s} {'-':>10s}  {message[:90]}")


def scale_table(tmp: Path) -> None:
    from autorig.samples import mannequin
    sample = mannequin(pose="a")
    joints = {}
    for factor in (0.001, 1.0, 1000.0):
        path = tmp / f"mannequin_x{factor:g}.obj"
        # Full precision: an exporter's fixed decimals would themselves change the mesh at x0.001.
        with open(path, "w") as fh:
            np.savetxt(fh, sample.vertices * factor, fmt="v %.17g %.17g %.17g")
            np.savetxt(fh, sample.faces + 1, fmt="f %d %d %d")
        out = tmp / f"mannequin_x{factor:g}.json"
        run = cli(str(path), "-o", str(out))
        if run.returncode:
            print(f"x{factor:g}: failed: {run.stderr.strip()}")
            return
        data = json.loads(out.read_text())
        joints[factor] = np.array([j["position"] for j in data["joints"]]) / factor
    height = float(np.ptp(sample.vertices[:, 1]))
    for factor in (0.001, 1000.0):
        diff = np.abs(joints[factor] - joints[1.0]).max() / height
        print(f"mannequin x{factor:<6g} vs x1: largest joint difference {diff:.2e} of the height")


def bad_inputs(tmp: Path, shared: Path) -> None:
    def write(name: str, text: str | bytes) -> Path:
        path = tmp / name
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        return path

    cube = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    cases = [
        ("missing file", [str(tmp / "nope.obj")]),
        ("not a mesh (text)", [str(write("notes.obj", "hello world\nthis is not a mesh\n"))]),
        ("garbage bytes", [str(write("garbage.ply", bytes(range(256)) * 8))]),
        ("empty mesh", [str(write("empty.obj", ""))]),
        ("point cloud", [str(write("cloud.obj", "".join(f"v {i} {i * i % 7} {i % 3}\n" for i in range(50))))]),
        ("NaN coordinates", [str(write("nan.obj", cube.replace("v 1 0 0", "v nan 0 0")))]),
        ("inf coordinates", [str(write("inf.obj", cube.replace("v 1 0 0", "v inf 0 0")))]),
        ("single triangle", [str(write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"))]),
        ("flat 2D mesh (woody.obj)", [str(shared / "data" / "meshes" / "woody.obj")]),
        ("unknown template", [str(write("cube.obj", cube)), "--template", "dragon"]),
        ("malformed template file", [str(tmp / "cube.obj"), "--template",
                                     str(write("bad_template.json", '{"joints": [{"name": "a"}]}'))]),
        ("unwritable output path", [str(tmp / "cube.obj"), "-o", str(tmp / "no" / "such" / "dir" / "out.glb")]),
        ("a cylinder as a biped, --strict", [str(shared / "data" / "rigged" / "RiggedSimple" / "mesh.obj"),
                                              "--strict", "-o", str(tmp / "strict.glb")]),
    ]
    print(f"{'bad input':34s} {'exit':>4s}  message")
    for label, args in cases:
        before = set(tmp.iterdir())
        run = cli(*args)
        lines = run.stderr.strip().splitlines()
        new = [p.name for p in set(tmp.iterdir()) - before]
        note = f"  (wrote {new})" if new else ""
        one_line = "" if len(lines) == 1 else f"  [{len(lines)} lines on stderr]"
        print(f"{label:34s} {run.returncode:4d}  {lines[-1] if lines else ''}{one_line}{note}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if (args.shared / "data").is_dir():
            shared_table(args.shared, tmp)
            print()
        scale_table(tmp)
        print()
        bad = tmp / "bad"
        bad.mkdir()
        bad_inputs(bad, args.shared)
    return 0


if __name__ == "__main__":
    sys.exit(main())
