"""Write the sample characters shipped in data/: the README's mannequin and a dog, each as an OBJ mesh and a
joints file with the exact skeleton it was built around.

    python data/build_samples.py

Output (next to this script):
    mannequin.obj, mannequin.joints.json   adult in the T-pose, 1.70 m tall, biped template joints
    dog.obj, dog.joints.json               dog standing on all fours, quadruped template joints

The joints files follow the layout of the rigged reference data: {"name", "joints": [{"name", "parent",
"position"}], "up_axis", "front_axis", "left_axis", "height_along_up", ...}, joints parents-first in the
template's order. Running the script again rewrites identical files.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

from autorig.samples import Sample, mannequin, quadruped  # noqa: E402
from autorig.template import load_template  # noqa: E402


def write_obj(path: Path, sample: Sample) -> None:
    """Vertices in metres to the micrometre, faces 1-based as OBJ counts them."""
    v = "\n".join(f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in sample.vertices)
    f = "\n".join(f"f {a} {b} {c}" for a, b, c in sample.faces + 1)
    path.write_text(f"# autorig sample: {path.stem}, +y up, +z front, metres\n{v}\n{f}\n")


def write_joints(path: Path, name: str, sample: Sample, source: str) -> None:
    template = load_template(ROOT / "templates" / f"{sample.template}.json")
    joints = [
        {"name": n,
         "parent": template.names[p] if p >= 0 else None,
         "position": [round(float(c), 6) for c in sample.joints[n]]}
        for n, p in zip(template.names, template.parents)
    ]
    heights = sample.vertices[:, 1]
    data = {
        "name": name,
        "source": source,
        "category": sample.template,
        "joints": joints,
        "up_axis": "+y",
        "front_axis": "+z",
        "left_axis": "+x",
        "height_along_up": round(float(heights.max() - heights.min()), 6),
        "mesh_stats": {"vertices": len(sample.vertices), "faces": len(sample.faces)},
    }
    path.write_text(json.dumps(data, indent=1) + "\n")


def main() -> None:
    builds = [
        ("mannequin", mannequin(pose="t", proportions="adult"), 'autorig.samples.mannequin(pose="t", proportions="adult")'),
        ("dog", quadruped(proportions="dog"), 'autorig.samples.quadruped(proportions="dog")'),
    ]
    for name, sample, source in builds:
        write_obj(HERE / f"{name}.obj", sample)
        write_joints(HERE / f"{name}.joints.json", name, sample, source)
        size = max((HERE / f).stat().st_size for f in (f"{name}.obj", f"{name}.joints.json"))
        print(f"{name}: {len(sample.vertices)} vertices, {len(sample.faces)} faces, "
              f"height {np.ptp(sample.vertices[:, 1]):.3f} m, largest file {size / 1e3:.0f} kB")


if __name__ == "__main__":
    main()
