"""What each output format costs: the time to write a finished rig as glb, gltf, json, usda, usdc, usdz and fbx,
and the time to read the input's look (UVs, materials, textures) beside its shape.

    python benchmarks/formats.py [--runs 5]

Rigs the textured characters of ../shared/data/textured (CesiumMan.glb, the Babi pig OBJ+MTL+PNG) and the
project's mannequin (no look) once each, then times every writer ``--runs`` times (FBX: Blender started each
time, so fewer runs) and prints the medians in milliseconds. USD needs usd-core, FBX Blender; a missing one
is reported, not timed.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import autorig  # noqa: E402
from autorig.errors import OutputError  # noqa: E402
from autorig.exchange import write_rig  # noqa: E402
from autorig.input.look import load_look  # noqa: E402
from autorig.input.mesh import load_mesh  # noqa: E402

TEXTURED = ROOT.parent / "shared" / "data" / "textured"
CASES = [("CesiumMan.glb", TEXTURED / "CesiumMan.glb", "biped"),
         ("Babi.obj", TEXTURED / "Babi" / "Babi.obj", "quadruped"),
         ("mannequin.obj", ROOT / "data" / "mannequin.obj", "biped")]
FORMATS = ["glb", "gltf", "json", "usda", "usdc", "usdz", "fbx"]


def median_ms(action, runs: int) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return 1000 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    print(f"median of {args.runs} runs (fbx: {max(1, args.runs // 2)}), milliseconds")
    print(f"{'input':<15} {'V':>6} {'out V':>6} {'rig':>7} {'look':>6} " + " ".join(f"{f:>7}" for f in FORMATS))
    with tempfile.TemporaryDirectory() as scratch:
        for label, path, template in CASES:
            if not path.is_file():
                print(f"{label:<15} missing")
                continue
            start = time.perf_counter()
            rig = autorig.rig(str(path), template)
            rig_ms = 1000 * (time.perf_counter() - start)
            faces = load_mesh(path)[1]
            look_ms = median_ms(lambda: load_look(path, faces), args.runs)
            cells = []
            for fmt in FORMATS:
                out = Path(scratch, f"{path.stem}.{fmt}")
                runs = max(1, args.runs // 2) if fmt == "fbx" else args.runs
                try:
                    cells.append(f"{median_ms(lambda: write_rig(rig, out, fmt), runs):7.1f}")
                except OutputError as e:
                    cells.append(f"{'n/a':>7}")
                    print(f"  {fmt}: {e}", file=sys.stderr)
            out_vertices = len(rig.look.vertex_of) if rig.look is not None else len(rig.vertices)
            print(f"{label:<15} {len(rig.vertices):6d} {out_vertices:6d} {rig_ms:7.0f} {look_ms:6.1f} "
                  + " ".join(cells))


if __name__ == "__main__":
    main()
