"""A studio's own skeleton: learn a template from rigged .glb files and rig characters left out of them.

    python benchmarks/studio_skeleton.py [--shared ../shared] [--examples 8] [--out DIR]

The studio skeleton is the corpus's own 0 A.D. biped (``shared/data/train``, 44 joints: two spine joints,
clavicles, fingers, prop sockets and IK targets). Every biped character is rigged on it with
``autorig.skin`` (what ``autorig MESH --skeleton joints.json`` does) and written as .glb; a template is learned
with ``autorig.learn`` from the first ``--examples`` body meshes (in name order) and every other character is
rigged with it (axes given) and compared joint by joint with its artist's skeleton: the error of each joint
the learned template has (helpers included, tips excluded), as a fraction of the height.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--examples", type=int, default=8)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    import autorig
    from autorig.exchange import write_rig
    from autorig.learn import learn_template

    train = args.shared / "data" / "train"
    folders = [p for p in sorted(train.iterdir()) if "biped_map" in json.loads((p / "joints.json").read_text())]
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        files = []
        for folder in folders:
            path = out / f"{folder.name}.glb"
            if not path.exists():
                write_rig(autorig.skin(folder / "mesh.obj", folder / "joints.json"), path, "glb")
            files.append(path)
        start = time.perf_counter()
        learned = learn_template(files[:args.examples], name="studio")
        template = learned.template
        (out / "studio.json").write_text(json.dumps(template.to_dict()))
        print(f"learned from {args.examples} rigs in {time.perf_counter() - start:.0f} s: {len(template.names)} joints "
              f"({sum(template.is_tip(j) for j in range(len(template.names)))} tips), {len(template.helpers)} helpers")
        print(f"{'model':38s} {'mean %':>7s} {'worst %':>8s} {'worst joint':>14s} {'weighted mean/worst':>20s} {'conf':>5s}")
        means, worsts, wmeans, wworsts = [], [], [], []
        for folder in folders[args.examples:]:
            meta = json.loads((folder / "joints.json").read_text())
            truth = {j["name"]: np.array(j["position"]) for j in meta["joints"]}
            weighted = {j["name"] for j in meta["joints"] if j.get("weighted")}
            height = meta["height_along_up"]
            rig = autorig.rig(folder / "mesh.obj", out / "studio.json", autorig.RigOptions(up="y", front="z"))
            errors = {n: float(np.linalg.norm(rig.joints[i] - truth[n]) / height)
                      for i, n in enumerate(rig.names) if n in truth and not n.endswith("_end")}
            worst = max(errors, key=errors.get)
            w = [v for n, v in errors.items() if n in weighted]
            means.append(np.mean(list(errors.values())))
            worsts.append(errors[worst])
            wmeans.append(np.mean(w))
            wworsts.append(np.max(w))
            print(f"{folder.name:38s} {100 * means[-1]:7.1f} {100 * worsts[-1]:8.1f} {worst:>14s} "
                  f"{100 * wmeans[-1]:9.1f} / {100 * wworsts[-1]:5.1f} {rig.info['confidence']:5.2f}", flush=True)
        print(f"\n{len(means)} characters left out: mean {100 * np.mean(means):.1f} % (worst character "
              f"{100 * np.max(means):.1f}), worst joint {100 * np.max(worsts):.1f} % (median {100 * np.median(worsts):.1f}); "
              f"weighted joints only: mean {100 * np.mean(wmeans):.1f} %, worst {100 * np.max(wworsts):.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
