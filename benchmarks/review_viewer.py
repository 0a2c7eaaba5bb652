"""The review page's 3D view on the shared meshes: the page's size and three.js's share of it, and in headless
Chromium how long each rig takes to open in the view and how fast its motion plays.

    python benchmarks/review_viewer.py [--shared ../shared] [--keep DIR] [--jobs 2]

The folder is review_page.py's (symlinks to ``shared/data/meshes/*.obj`` in a temporary directory, never in the
repo, with its mixed templates: biped, quadruped, horse, auto). One ``autorig batch --html`` rigs them; then:

- bytes: the page (review.html: cards, thumbnails, the viewer's script and data, the rigs inlined within
  ``INLINE_BUDGET``), three.js beside it, the rigs' .glb files; three.js's share of what a reviewer downloads
  (page + three.js), and of page + three.js + the rigs not inlined (what the page reads when it is served);
- the page's load event from disk in Chromium (3 loads; the inlined rigs are parsed as text, decoded only when
  opened);
- per rig, in Chromium (1300 x 950 window, SwiftShader WebGL as in CI): the time from the click on "3D view"
  to a drawn rig (bytes decoded, glTF parsed, first frame), and the motion's frames per second over 2 s.
"""
from __future__ import annotations

import argparse
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

from review_page import MIXED_CONFIG  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    parser.add_argument("--keep", type=Path, help="work here instead of a temporary directory (kept)")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    meshes = args.shared / "data" / "meshes"
    if not meshes.is_dir():
        print(f"no shared meshes at {meshes}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="autorig-viewer-bench-") as scratch:
        work = args.keep or Path(scratch)
        assets, out = work / "assets", work / "rigged"
        assets.mkdir(parents=True, exist_ok=True)
        for mesh in sorted(meshes.glob("*.obj")):
            if not (assets / mesh.name).exists():
                (assets / mesh.name).symlink_to(mesh.resolve())
        (assets / "autorig.toml").write_text(MIXED_CONFIG)
        page = out / "review.html"
        command = [sys.executable, "-m", "autorig.cli", "batch", str(assets), "-o", str(out), "-j", str(args.jobs),
                   "-q", "--allow-outside-paths", "--html", str(page), "--report", str(work / "report.json")]
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode not in (0, 7):
            raise SystemExit(f"{' '.join(command)} exited with {done.returncode}: {done.stderr[-2000:]}")
        print(f"batch with --html: {time.perf_counter() - started:.1f} s")
        sizes(page, out, work / "report.json")
        from chromium import EXECUTABLE
        if EXECUTABLE is None:
            print("chromium is not installed: no browser measurements")
            return 0
        in_the_browser(page)
    return 0


def views_of(page: Path) -> list:
    text = page.read_text(encoding="utf-8")
    marker = '<script type="application/json" id="views">'
    start = text.index(marker) + len(marker)
    return json.loads(text[start:text.index("</script>", start)])


def sizes(page: Path, out: Path, report: Path) -> None:
    from autorig.show.viewer import INLINE_BUDGET, THREE_FILE
    views = [v for v in views_of(page) if v]
    page_bytes, three = page.stat().st_size, (out / THREE_FILE).stat().st_size
    rigs = {v["output"]: (out / v["output"]).stat().st_size for v in views}
    inlined = sum(rigs[v["output"]] for v in views if v["inline"])
    left_out = sum(rigs[v["output"]] for v in views if not v["inline"])
    assets = json.loads(report.read_text())["assets"]
    print(f"{len(assets)} assets, {len(views)} rigs with a 3D view; inline budget {INLINE_BUDGET:,} bytes")
    print(f"{'rig':<26}{'glb bytes':>12}  inlined")
    for v in views:
        print(f"{v['output']:<26}{rigs[v['output']]:>12,}  {'yes' if v['inline'] else 'no: read from its file'}")
    print(f"review.html: {page_bytes:,} bytes (rigs inlined: {inlined:,} bytes of .glb, as base64)")
    print(f"three.js beside it ({THREE_FILE}): {three:,} bytes = {three / (page_bytes + three):.1%} of page + "
          f"three.js ({page_bytes + three:,} bytes)")
    print(f"rigs not inlined: {left_out:,} bytes; three.js = {three / (page_bytes + three + left_out):.1%} of page + "
          f"three.js + those rigs ({page_bytes + three + left_out:,} bytes)")
    print(f"all .glb rigs: {sum(rigs.values()):,} bytes")
    from autorig.show.viewer import WEB
    script = (WEB / "viewer.js").stat().st_size
    print(f"the viewer's own script (inline in the page): {script:,} bytes; with three.js, the viewer is "
          f"{(script + three) / (page_bytes + three):.1%} of page + three.js")


def in_the_browser(page: Path) -> None:
    """Open every rig from the page's own folder (http, so that the rigs left out are read too)."""
    import functools
    import http.server
    import threading

    from chromium import Chromium

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(page.parent)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        with Chromium(width=1300, height=950, timeout=300) as browser:
            loads = []
            for _ in range(3):
                browser.open(page)
                loads.append(browser.evaluate("performance.getEntriesByType('navigation')[0].loadEventEnd"))
            print(f"\nthe page from disk: load event after {', '.join(f'{t:.0f}' for t in loads)} ms (3 loads)")
            browser.open_url(f"http://127.0.0.1:{server.server_address[1]}/{page.name}")
            names = browser.evaluate("Array.from(document.querySelectorAll('button.view3d'), "
                                     "b => b.closest('article').dataset.name)")
            print(f"\nin Chromium (SwiftShader), over http from the page's folder:")
            print(f"{'asset':<20}{'open ms':>9}{'motion fps':>12}  state")
            opens, rates = [], []
            for name in names:
                milliseconds = browser.evaluate(
                    "new Promise(done => { const t = performance.now(); "
                    f"document.querySelector('article[data-name={json.dumps(name)}] button.view3d').click(); "
                    "const poll = () => document.getElementById('viewer').dataset.state === 'loading' ? "
                    "setTimeout(poll, 5) : requestAnimationFrame(() => done(performance.now() - t)); poll(); })")
                state = browser.evaluate("document.getElementById('viewer').dataset.state")
                fps = browser.evaluate(
                    "new Promise(done => { document.getElementById('view-move').click(); let n = 0; "
                    "const t = performance.now(); const count = () => { n++; performance.now() - t < 2000 ? "
                    "requestAnimationFrame(count) : done(n / (performance.now() - t) * 1000); }; "
                    "requestAnimationFrame(count); })")
                browser.evaluate("document.getElementById('view-move').click(); document.getElementById('view-close')"
                                 ".click()")
                opens.append(milliseconds)
                rates.append(fps)
                print(f"{name:<20}{milliseconds:>9.0f}{fps:>12.1f}  {state}")
            print(f"open: median {statistics.median(opens):.0f} ms, max {max(opens):.0f} ms; motion: median "
                  f"{statistics.median(rates):.1f} fps, min {min(rates):.1f} fps")
    finally:
        server.shutdown()
        server.server_close()
    print("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))


if __name__ == "__main__":
    sys.exit(main())
