"""What ``autorig batch --html`` costs per asset, in time and bytes, on the shared real meshes; and a page of
1,000 assets in headless Chromium.

    python benchmarks/review_page.py [--shared ../shared] [--runs 3] [--scale 1000] [--artifacts DIR] [--keep DIR]

The folder is made in a temporary directory (never in the repo) of symlinks to ``shared/data/meshes/*.obj``, with
an ``autorig.toml`` of mixed templates: batch_speed.py's (biped by default, quadruped for cow, spot and
alligator, horse for the horse) plus template "auto" for the octopus and the spider. Measured:

- wall time of ``autorig batch --force -j 2`` in a fresh process with and without ``--html`` (median of
  ``--runs``, runs alternating so that other load falls on both alike): the difference per asset;
- the workers' own ``thumbnails`` stage per rigged asset (from the JSON report; median over runs), which is
  what the page adds to each asset's work without the noise of a shared machine;
- the time to write the page (``write_review``, median of 5) and its bytes, per asset; the thumbnails' bytes;
- a page of ``--scale`` assets (the shared ones repeated under new names, the same pictures): its bytes, the
  time to write it, and in Chromium the time to its load event, how many images were decoded by then (lazy
  loading), the JS heap, and how long the filter takes to answer a typed word.

With ``--artifacts DIR`` the shared batch's page is screenshotted to DIR/review-shared-meshes.png (and a
filtered view to DIR/review-filter-quadruped.png).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests")]

from batch_speed import CONFIG  # noqa: E402  (the same per-asset templates and axes)

MIXED_CONFIG = CONFIG + '\n[files."octopus_low.obj"]\ntemplate = "auto"\n\n[files."spider.obj"]\ntemplate = "auto"\n'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--runs", type=int, default=3, help="timed runs with and without --html")
    parser.add_argument("--scale", type=int, default=1000, help="assets on the large synthetic page")
    parser.add_argument("--artifacts", type=Path, help="save screenshots of the shared batch's page here")
    parser.add_argument("--keep", type=Path, help="work here instead of a temporary directory (kept)")
    args = parser.parse_args()

    meshes = args.shared / "data" / "meshes"
    if not meshes.is_dir():
        print(f"no shared meshes at {meshes}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="autorig-review-bench-") as scratch:
        work = args.keep or Path(scratch)
        assets = work / "assets"
        assets.mkdir(parents=True, exist_ok=True)
        for mesh in sorted(meshes.glob("*.obj")):
            if not (assets / mesh.name).exists():
                (assets / mesh.name).symlink_to(mesh.resolve())
        (assets / "autorig.toml").write_text(MIXED_CONFIG)
        count = len(list(assets.glob("*.obj")))
        print(f"{count} assets in {assets}, {args.runs} run(s) each; load average {os.getloadavg()[0]:.1f} on "
              f"{os.cpu_count()} CPUs\n")

        walls: dict[str, list[float]] = {"plain": [], "html": []}
        thumbnail_stage: dict[str, list[float]] = {}
        for _ in range(args.runs):
            for mode in walls:
                out = work / f"out-{mode}"
                flags = ["--html", str(out / "review.html")] if mode == "html" else []
                walls[mode].append(run_batch(assets, out, work / f"{mode}.json", flags))
            for asset in json.loads((work / "html.json").read_text())["assets"]:
                if "thumbnails" in asset["timings"]:
                    thumbnail_stage.setdefault(asset["input"], []).append(asset["timings"]["thumbnails"])
        report = {a["input"]: a for a in json.loads((work / "html.json").read_text())["assets"]}
        out = work / "out-html"
        page = out / "review.html"
        result, write_seconds = page_write_time(assets, out, work / "resumed.html")

        print(f"{'asset':<18}{'status':<8}{'template':<11}{'faces':>8}{'rig s':>8}{'thumbs s':>10}{'share':>7}"
              f"{'thumb bytes':>13}")
        thumb_bytes = []
        stage_medians = []
        for asset in result.assets:
            faces = sum(1 for line in (assets / asset.input).open("rb") if line.startswith(b"f "))
            stage = statistics.median(thumbnail_stage[asset.input]) if asset.input in thumbnail_stage else None
            size = sum((out / rel).stat().st_size for rel in asset.thumbnails.values())
            rig_seconds = report[asset.input]["seconds"]
            if stage is not None:
                stage_medians.append(stage)
                thumb_bytes.append(size)
            print(f"{asset.input:<18}{'failed' if asset.failed else 'ok':<8}{asset.template:<11}{faces:>8}"
                  f"{rig_seconds:>8.2f}" + (f"{stage:>10.2f}{stage / rig_seconds:>7.0%}{size:>13,}"
                                            if stage is not None else f"{'-':>10}{'-':>7}{'-':>13}"))
        plain, html = statistics.median(walls["plain"]), statistics.median(walls["html"])
        page_bytes = page.stat().st_size
        print(f"\nwall time of the batch (-j 2, median of {args.runs}): {plain:.1f} s without --html, {html:.1f} s "
              f"with: {html - plain:+.1f} s, {(html - plain) / count:+.2f} s per asset ({html / plain - 1:+.0%})")
        print(f"thumbnails stage in the workers: median {statistics.median(stage_medians):.2f} s per rigged asset "
              f"(min {min(stage_medians):.2f}, max {max(stage_medians):.2f}; the first in each worker process "
              f"also imports matplotlib)")
        print(f"writing the page: {write_seconds * 1000:.0f} ms ({write_seconds / count * 1000:.1f} ms per asset)")
        print(f"page: {page_bytes:,} bytes, {page_bytes / count:,.0f} per asset; thumbnails (WebP, 160 px high): "
              f"median {statistics.median(thumb_bytes):,.0f} bytes per rigged asset for both views, "
              f"{sum(thumb_bytes):,} in all")

        big = work / "big" / "review.html"
        big_seconds, big_bytes = write_scaled_page(result, big, args.scale)
        print(f"\npage of {args.scale} assets: {big_bytes:,} bytes ({big_bytes / args.scale:,.0f} per asset), "
              f"written in {big_seconds:.2f} s")
        from chromium import EXECUTABLE
        if EXECUTABLE is None:
            print("chromium is not installed: no browser measurements")
            return 0
        for line in browser_measurements(big, args.scale):
            print("  " + line)
        if args.artifacts:
            for path in screenshots(page, args.artifacts):
                print(f"screenshot: {path}")
        print("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))
    return 0


def run_batch(assets: Path, out: Path, report: Path, flags: list[str]) -> float:
    """Wall time of one ``autorig batch --force -j 2`` in a fresh process."""
    command = [sys.executable, "-m", "autorig.cli", "batch", str(assets), "-o", str(out), "--force", "-j", "2",
               "-q", "--report", str(report), *flags]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if done.returncode not in (0, 7):
        raise SystemExit(f"{' '.join(command)} exited with {done.returncode}: {done.stderr[-2000:]}")
    return seconds


def page_write_time(assets: Path, out: Path, page: Path):
    """(the resumed batch's result, median seconds of ``write_review`` over 5 writes): the timed run's page is
    left as it was, for the screenshots."""
    from autorig.batch import rig_folder
    from autorig.batch.review import write_review

    result = rig_folder(assets, out, html=page)  # every asset unchanged: only the page is written again
    # The resumed run's result has the skipped statuses; the page reads the same thumbnails and fields.
    times = []
    for _ in range(5):
        started = time.perf_counter()
        write_review(result, page)
        times.append(time.perf_counter() - started)
    return result, statistics.median(times)


def write_scaled_page(result, path: Path, scale: int) -> tuple[float, int]:
    """A page of ``scale`` assets: ``result``'s repeated under new names (the same thumbnails, so the same bytes
    each), written beside a copy of nothing: the links point at the real output folder."""
    from autorig.batch import BatchResult
    from autorig.batch.review import write_review

    assets = [dataclasses.replace(a, input=f"copy{i // len(result.assets):03d}/{a.input}")
              for i, a in zip(range(scale), (result.assets * (scale // len(result.assets) + 1)))]
    big = BatchResult(result.input_dir, result.output_dir, assets, result.seconds)
    path.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    write_review(big, path)
    return time.perf_counter() - started, path.stat().st_size


def browser_measurements(page: Path, scale: int) -> list[str]:
    from chromium import Chromium

    lines = []
    with Chromium(width=1400, height=1000) as browser:
        started = time.perf_counter()
        browser.open(page, query="sort=name")  # the review order starts with cards that have no pictures
        opened = time.perf_counter() - started
        navigation = browser.evaluate("(e => e.loadEventEnd - e.startTime)"
                                      "(performance.getEntriesByType('navigation')[0])")
        images = browser.evaluate("document.images.length")
        decoded = browser.evaluate("Array.from(document.images).filter(i => i.complete && i.naturalWidth > 0)"
                                   ".length")
        time.sleep(1.0)
        on_screen = browser.evaluate("Array.from(document.images).filter(i => i.complete && i.naturalWidth > 0)"
                                     ".length")
        browser.command("Performance.enable")
        metrics = {m["name"]: m["value"] for m in browser.command("Performance.getMetrics")["metrics"]}
        lines.append(f"Chromium: load event {navigation:.0f} ms after navigation ({opened:.2f} s as the test sees "
                     f"it); {decoded} of {images} images decoded at load, {on_screen} a second later (lazy loading: those near "
                     f"the window); JS heap "
                     f"{metrics.get('JSHeapUsedSize', 0) / 1e6:.1f} MB; {metrics.get('Nodes', 0):.0f} DOM nodes")
        answers = []
        for word in ("spider", "quadruped", "failed", ""):
            started = time.perf_counter()
            browser.type_into("#filter", word)
            shown = browser.evaluate("document.getElementById('shown').textContent")
            answers.append((word or "(cleared)", time.perf_counter() - started, shown))
        lines.append("filter over CDP (typing and reading back): " + ", ".join(
            f"{word!r} {seconds * 1000:.0f} ms -> {shown}" for word, seconds, shown in answers))
        started = time.perf_counter()
        browser.evaluate("(m => { m.value = 'time'; m.dispatchEvent(new Event('change')); })"
                         "(document.getElementById('sort'))")
        lines.append(f"sort by time over {scale} cards: {(time.perf_counter() - started) * 1000:.0f} ms")
    return lines


def screenshots(page: Path, folder: Path) -> list[Path]:
    from chromium import Chromium

    folder.mkdir(parents=True, exist_ok=True)
    saved = []
    with Chromium(width=1400, height=1000) as browser:
        browser.open(page)
        browser.evaluate("Promise.all(Array.from(document.images, i => i.decode()))")
        saved.append(browser.screenshot(folder / "review-shared-meshes.png"))
        browser.open(page, query="q=quadruped")
        browser.evaluate("Promise.all(Array.from(document.images, i => i.decode()))")
        saved.append(browser.screenshot(folder / "review-filter-quadruped.png"))
    return saved


if __name__ == "__main__":
    sys.exit(main())
