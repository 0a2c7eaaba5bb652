"""``autorig batch`` on the shared real meshes: -j 1 against -j 2, and a Dask LocalCluster of 2 workers.

    python benchmarks/batch_speed.py [--shared ../shared] [--runs 3] [--no-cluster] [--keep DIR]

The folder is made in a temporary directory (never in the repo) of copies of ``shared/data/meshes/*.obj`` and
``shared/data/rigged/*/mesh.obj`` (as ``rigged/<name>.obj``), with an ``autorig.toml`` that gives each its
template and axes. Some are not bipeds or not even volumes (woody and alligator are flat cut-outs, spider is in
pieces, octopus has eight legs, RiggedSimple and huesitos are tubes): they rig or fail cleanly, which is the
point. Each timed run is the command line as a user runs it, ``autorig batch ... --force`` in a fresh
process, wall time from start to exit, worker start-up included. The LocalCluster is started beforehand and
its start-up is not counted: ``--scheduler`` is for a cluster that already exists.

Checked along the way: every asset is ``ok`` or ``failed`` with a one-line error, the JSON and JUnit reports
parse, a second run without --force skips everything, and -j 2 and the cluster write byte-identical outputs
to -j 1's. Prints a table per asset and one per mode.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LOADS: list[float] = []  # the 1-minute load average before each run

# Per asset, where the default (biped, +y up, facing +z) is not right. From shared/data/MANIFEST.md and the
# rigged characters' joints.json.
CONFIG = """\
template = "biped"
up = "y"
front = "z"

[files."cow.obj"]
template = "quadruped"
front = "x"

[files."spot.obj"]
template = "quadruped"
front = "-z"

[files."horse.obj"]
template = "horse"
up = "z"
front = "y"

[files."alligator.obj"]
template = "quadruped"

[files."rigged/CesiumMan.obj"]
front = "x"

[files."rigged/Fox.obj"]
template = "quadruped"
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--runs", type=int, default=3, help="timed runs per mode; the median is reported")
    parser.add_argument("--no-cluster", action="store_true", help="skip the Dask LocalCluster")
    parser.add_argument("--keep", type=Path, help="work here instead of a temporary directory (kept)")
    args = parser.parse_args()

    data = args.shared / "data"
    if not (data / "meshes").is_dir():
        print(f"no shared data at {data}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="autorig-batch-bench-") as scratch:
        work = args.keep or Path(scratch)
        work.mkdir(parents=True, exist_ok=True)
        assets = make_folder(data, work / "assets")
        print(f"{len(list(assets.rglob('*.obj')))} assets in {assets}, {args.runs} run(s) per mode; load average "
              f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs\n")

        modes = {"-j 1": ["-j", "1"], "-j 2": ["-j", "2"]}
        with contextlib.ExitStack() as stack:
            if not args.no_cluster:
                from distributed import LocalCluster
                started = time.perf_counter()
                cluster = stack.enter_context(LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                                           host="127.0.0.1", dashboard_address=None))
                print(f"LocalCluster of 2 workers up in {time.perf_counter() - started:.1f} s (not counted)\n")
                modes["cluster 2"] = ["--scheduler", cluster.scheduler_address]
            # Round by round rather than mode by mode, so that load from other processes on the machine
            # falls on every mode alike.
            times: dict[str, list[float]] = {name: [] for name in modes}
            for _ in range(args.runs):
                for name, flags in modes.items():
                    times[name].append(batch(assets, work / f"out {name}", work / f"{name}.json",
                                             work / f"{name}.xml", flags + ["--force"], name))

        reference = work / "out -j 1"
        results = {name: check_reports(work / f"{name}.json", work / f"{name}.xml") for name in modes}
        identical = {name: same_outputs(reference, work / f"out {name}") for name in modes if name != "-j 1"}
        resumed = batch(assets, reference, work / "resume.json", work / "resume.xml", [], "-j 1, again")
        skipped = {a["status"] for a in json.loads((work / "resume.json").read_text())["assets"]} == {"skipped"}
        print(f"\nsecond run without --force: {resumed:.1f} s, everything skipped: {skipped}")
        print("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.1f}" for x in os.getloadavg()) + "\n")

        print_assets(results["-j 1"])
        print_modes(times, results, identical)
        outcomes = {name: {rel: a["status"] for rel, a in res.items()} for name, res in results.items()}
        agree = all(o == outcomes["-j 1"] for o in outcomes.values())
        print(f"same ok/failed per asset in every mode: {agree}")
        if max(LOADS) > os.cpu_count():
            print(f"the machine was busy with other work (load average above its {os.cpu_count()} CPUs): "
                  "the wall times and speed-ups above are not what an idle machine gives")
        return 0 if skipped and agree and all(identical.values()) else 1


def make_folder(data: Path, folder: Path) -> Path:
    # Copies, not symlinks: a batch refuses an asset whose symlink leads out of its input folder.
    (folder / "rigged").mkdir(parents=True, exist_ok=True)
    for mesh in sorted((data / "meshes").glob("*.obj")):
        copy = folder / mesh.name
        if not copy.exists():
            shutil.copyfile(mesh, copy)
    for mesh in sorted((data / "rigged").glob("*/mesh.obj")):
        copy = folder / "rigged" / f"{mesh.parent.name}.obj"
        if not copy.exists():
            shutil.copyfile(mesh, copy)
    (folder / "autorig.toml").write_text(CONFIG)
    return folder


def batch(assets: Path, out: Path, report: Path, junit: Path, flags: list[str], label: str) -> float:
    """Wall time of one ``autorig batch`` run in a fresh process.

    Also printed: the CPU time of that process and its worker processes (not a cluster's workers, which are
    not its children), and the machine's load average just before: on a shared machine, a run whose wall
    time is far above its CPU time / jobs was waiting for cores that other processes held."""
    command = [sys.executable, "-m", "autorig.cli", "batch", str(assets), "-o", str(out), "-q",
               "--report", str(report), "--junit", str(junit), *flags]
    load = os.getloadavg()[0]
    LOADS.append(load)
    cpu = _children_cpu()
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    cpu = _children_cpu() - cpu
    if done.returncode not in (0, 7):
        sys.exit(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr}")
    print(f"  {label:<12} {seconds:7.1f} s wall {cpu:7.1f} s CPU   load before {load:.1f}", flush=True)
    return seconds


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def check_reports(report: Path, junit: Path) -> dict[str, dict]:
    """The JSON report's assets by input, after checking that both reports parse and agree."""
    assets = {a["input"]: a for a in json.loads(report.read_text())["assets"]}
    cases = list(ET.parse(junit).getroot().iter("testcase"))
    assert len(cases) == len(assets), (len(cases), len(assets))
    failures = sum(case.find("failure") is not None for case in cases)
    assert failures == sum(a["status"] == "failed" for a in assets.values())
    for asset in assets.values():
        assert asset["status"] in ("ok", "failed"), asset
        assert asset["status"] == "ok" or (asset["error"] and "\n" not in asset["error"]), asset
    return assets


def same_outputs(a: Path, b: Path) -> bool:
    def files(folder: Path) -> dict[str, bytes]:
        return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*.glb"))}
    return files(a) == files(b)


def print_assets(assets: dict[str, dict]) -> None:
    print(f"{'asset':<34} {'template':<10} {'up':>3} {'front':>5} {'status':<7} {'s (-j 1)':>8} {'conf':>5}  error")
    for rel, a in assets.items():
        conf = f"{a['confidence']:.2f}" if a["confidence"] is not None else ""
        print(f"{rel:<34} {a['template']:<10} {a['up']:>3} {a['front']:>5} {a['status']:<7} {a['seconds']:8.1f} "
              f"{conf:>5}  {a['error'] or ''}")
    print()


def print_modes(times: dict[str, list[float]], results: dict[str, dict], identical: dict[str, bool]) -> None:
    base = statistics.median(times["-j 1"])
    print(f"{'mode':<10} {'median s':>9} {'runs':<24} {'speed-up':>8} {'ok':>3} {'failed':>6}  outputs == -j 1")
    for name, runs in times.items():
        median = statistics.median(runs)
        statuses = [a["status"] for a in results[name].values()]
        same = "(reference)" if name == "-j 1" else ("byte-identical" if identical[name] else "DIFFERENT")
        print(f"{name:<10} {median:9.1f} {' '.join(f'{t:.1f}' for t in runs):<24} {base / median:7.2f}x "
              f"{statuses.count('ok'):>3} {statuses.count('failed'):>6}  {same}")


if __name__ == "__main__":
    sys.exit(main())
