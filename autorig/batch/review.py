"""A page to review a batch by eye (``autorig batch ... --html review.html``): one card per asset, doubtful first.

    from autorig.batch.review import write_review
    write_review(rig_folder("assets/", "rigged/", html=None), "review.html")   # rig_folder(html=...) does this

The page is one self-contained HTML file: its style, script and thumbnails (WebP, a few kilobytes per view,
as data: URIs) are inside it, and its Content-Security-Policy forbids any fetch, so it opens the same from
disk, from a CI artifact or offline. Only the links to the rigs point outside it (relative to the page).

Contents: a summary (assets by status, rigs below the low-confidence threshold, the batch's time); then one
card per asset with the front and side thumbnails the workers drew (``AssetResult.thumbnails``), the name
linked to the output, the template and axes, the confidence with its parts (weak parts marked), the stage
times (for a skipped asset, those of the run that rigged it) and a failure's one-line error. Cards come in
review order: assets without a rig, then rigs below ``STRICT_THRESHOLD`` (lowest first), then the rest as
the batch lists them. A filter box keeps the cards holding every word typed (name, template, status, error;
``?q=words`` in the page's address fills it) and a menu sorts by name, confidence or time (``?sort=``).

For a thousand assets the page stays light: the cards' layout and painting wait until they scroll near
(``content-visibility``), the images decode lazily, and the bytes are mostly the thumbnails' (see
benchmarks/review_page.py).
"""
from __future__ import annotations

import base64
import html
import os
from pathlib import Path, PurePosixPath
from urllib.parse import quote

from ..confidence import STRICT_THRESHOLD
from .result import AssetResult, BatchResult

__all__ = ["write_review", "review_page", "review_order"]

WEAK_PART = 0.8  # a confidence part below this is marked: it is what pulls the rig's confidence down
SLOWEST_SHOWN = 3  # stages named on the card itself; the others are in its list of stage times


def write_review(result: BatchResult, path: str | os.PathLike, low: float = STRICT_THRESHOLD) -> None:
    """Write the review page of ``result`` to ``path`` (atomically); links to the rigs are relative to it.

    low  confidence below which a rig counts as doubtful (default: where ``--strict`` stops)
    Raises ``OutputError`` if ``path`` cannot be written.
    """
    from ..exchange import write_file_atomic
    page = review_page(result, Path(os.path.abspath(path)).parent, low)
    write_file_atomic(path, page.encode("utf-8", "backslashreplace"))  # a file name's undecodable bytes


def review_order(assets: list[AssetResult], low: float = STRICT_THRESHOLD) -> list[AssetResult]:
    """``assets`` as the page shows them: without a rig first (in the batch's order), then rigs with a
    confidence below ``low`` (lowest first), then the rest in the batch's order."""
    def rank(item: tuple[int, AssetResult]):
        index, asset = item
        if asset.failed:
            return 0, 0.0, index
        if _is_low(asset, low):
            return 1, asset.confidence, index
        return 2, 0.0, index
    return [asset for _, asset in sorted(enumerate(assets), key=rank)]


def review_page(result: BatchResult, page_dir: Path, low: float = STRICT_THRESHOLD) -> str:
    """The page's HTML; ``page_dir`` is the folder it will be in (the links to the rigs start there)."""
    from ..version import __version__

    assets = review_order(result.assets, low)
    counts = result.counts
    doubtful = sum(_is_low(a, low) for a in result.assets)
    earlier_failed = sum(a.status == "skipped" and a.failed for a in result.assets)
    tiles = [("assets", len(result.assets), ""), ("ok", counts["ok"], "ok"),
             ("failed", counts["failed"], "failed" if counts["failed"] else ""),
             ("skipped", counts["skipped"], ""), ("doubtful", doubtful, "low" if doubtful else ""),
             ("total time", _seconds(result.seconds), "")]
    summary = "".join(f'<div class="tile {kind}"><b>{html.escape(str(value))}</b>{html.escape(label)}</div>'
                      for label, value, kind in tiles)
    notes = [f"{earlier_failed} of the skipped assets failed in the run that rigged them"] if earlier_failed else []
    notes.append(f"doubtful: confidence below {low:g}, probably wrong (look at its pictures); parts below "
                 f"{WEAK_PART:g} are marked")
    cards = "\n".join(_card(a, rank, result.output_dir, page_dir, low) for rank, a in enumerate(assets))
    title = f"autorig batch: {result.input_dir.name or result.input_dir}"
    return _PAGE.format(
        title=html.escape(title), summary=summary, cards=cards, total=len(assets), style=_STYLE, script=_SCRIPT,
        notes=html.escape("; ".join(notes)), version=html.escape(__version__),
        input=html.escape(str(result.input_dir)), output=html.escape(str(result.output_dir)))


def _is_low(asset: AssetResult, low: float) -> bool:
    return not asset.failed and asset.confidence is not None and asset.confidence < low


def _card(asset: AssetResult, rank: int, output_dir: Path, page_dir: Path, low: float) -> str:
    e = html.escape
    if asset.failed:
        kind, badge = "failed", "failed" + (" earlier" if asset.status == "skipped" else "")
    elif _is_low(asset, low):
        kind, badge = "low", "doubtful"
    else:
        kind, badge = "ok", "ok"
    if asset.status == "skipped" and not asset.failed:
        badge += ", unchanged"
    pictures = "".join(_picture(output_dir / rel, f"{view} of {asset.input}")
                       for view, rel in asset.thumbnails.items())
    if not pictures:
        pictures = f'<div class="nopic">{_no_picture(asset)}</div>'
    name = e(asset.input)
    if not asset.failed:
        link = os.path.relpath(os.path.abspath(output_dir / asset.output), page_dir)
        name = f'<a href="{e(quote(Path(link).as_posix(), errors="surrogateescape"))}">{name}</a>'
    axes = (f" · up {asset.up} · front {asset.front}" if asset.up else "") + (
        f" · markers {PurePosixPath(asset.markers).name}" if asset.markers else "")
    lines = [f'<p class="what">{e(asset.template + axes)}</p>']
    if asset.confidence is not None:
        parts = " ".join(f'<span class="part{" weak" if value < WEAK_PART else ""}">{e(part)} {value:.2f}</span>'
                         for part, value in asset.confidence_parts.items())
        lines.append(f'<p class="confidence">confidence <b>{asset.confidence:.2f}</b><br>{parts}</p>')
        if _is_low(asset, low):
            reasons = "; ".join(asset.confidence_reasons) or "no one part stands out"
            lines.append(f'<p class="error">probably wrong: {e(reasons)}</p>')
    timings = asset.timings or asset.previous_timings
    seconds = asset.seconds or sum(asset.previous_timings.values())
    if timings:
        # The slowest stages in sight, every stage (in pipeline order) one click away.
        slowest = sorted(timings, key=timings.get, reverse=True)[:SLOWEST_SHOWN]
        top = ", ".join(f"{e(stage)} {timings[stage]:.2f}" for stage in slowest)
        stages = "".join(f"<li>{e(stage)} <b>{value:.2f}</b></li>" for stage, value in timings.items())
        earlier = " in the run that rigged it" if asset.status == "skipped" else ""
        lines.append(f'<details class="times"><summary>{_seconds(seconds)}{earlier}: {top}</summary>'
                     f'<ol>{stages}</ol></details>')
    elif asset.seconds:
        lines.append(f'<p class="times">{_seconds(seconds)}</p>')
    if asset.failed and asset.error:
        lines.append(f'<p class="error">{e(asset.error)}</p>')
    words = " ".join([asset.input, asset.template, asset.status, kind, badge, asset.error or ""]).lower()
    confidence = -1.0 if asset.failed else (asset.confidence if asset.confidence is not None else 2.0)
    return (f'<article class="card {kind}" data-rank="{rank}" data-name="{e(asset.input)}" '
            f'data-confidence="{confidence:.4f}" data-seconds="{seconds:.3f}" data-text="{e(words)}">'
            f'<div class="pics">{pictures}</div><div class="about"><h2>{name}</h2>'
            f'<p class="badge">{e(badge)}</p>{"".join(lines)}</div></article>')


def _no_picture(asset: AssetResult) -> str:
    if asset.failed:
        return "no rig"
    if "thumbnails" in (asset.timings or asset.previous_timings):
        return "no picture: its worker could not draw one (Pillow missing there?)"
    return "no picture: rigged by a run without html (--force draws it)"


def _picture(path: Path, alt: str) -> str:
    """An <img> of the WebP thumbnail at ``path``, inlined; a missing file shows its alt text."""
    try:
        data = base64.b64encode(path.read_bytes()).decode("ascii")
    except OSError:
        return f'<div class="nopic">{html.escape(alt)}: picture missing</div>'
    return (f'<img src="data:image/webp;base64,{data}" alt="{html.escape(alt)}" loading="lazy" '
            f'decoding="async">')


def _seconds(value: float) -> str:
    return f"{value:.1f} s" if value < 600 else f"{value / 60:.1f} min"


# Every fetch is refused (default-src 'none'); only the inline style, the inline script and data: images run.
_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title><style>{style}</style></head>
<body><header><h1>{title}</h1><p class="paths">{input} &rarr; {output} · autorig {version}</p>
<div class="summary">{summary}</div><p class="notes">{notes}</p>
<div class="controls"><input id="filter" type="search" placeholder="filter: name, template, status, error"
 aria-label="filter" autocomplete="off"> <label>sort <select id="sort" aria-label="sort">
<option value="review">doubtful first</option><option value="name">name</option>
<option value="confidence">confidence, lowest first</option><option value="time">time, slowest first</option>
</select></label> <span id="shown">{total} of {total}</span></div></header>
<main id="cards">
{cards}
</main><script>{script}</script></body></html>
"""

_STYLE = """
body{font:14px/1.35 system-ui,sans-serif;margin:0 1.2em 2em;color:#222;background:#f4f4f2}
h1{font-size:20px;margin:.6em 0 .1em}.paths,.notes{color:#666;margin:.2em 0;font-size:12px;word-break:break-all}
.summary{display:flex;flex-wrap:wrap;gap:.5em;margin:.5em 0}
.tile{background:#fff;border:1px solid #ddd;border-radius:6px;padding:.3em .8em;min-width:5em}
.tile b{display:block;font-size:20px}.tile.failed{border-color:#c33;color:#a11}.tile.low{border-color:#d90;color:#850}
.controls{position:sticky;top:0;background:#f4f4f2;padding:.5em 0;z-index:1}
#filter{width:22em;padding:.3em}#shown{color:#666;margin-left:.5em}
main{display:grid;align-items:start;grid-template-columns:repeat(auto-fill,minmax(330px,1fr));gap:.6em}
.card{background:#fff;border:1px solid #ddd;border-top:5px solid #6a6;border-radius:6px;padding:.5em;
content-visibility:auto;contain-intrinsic-size:auto 330px}
.card.failed{border-top-color:#c33}.card.low{border-top-color:#e90}.card[hidden]{display:none}
.pics{display:flex;gap:6px;height:160px;align-items:center;justify-content:center;margin-bottom:.3em}
.pics img{height:auto;max-height:160px;max-width:calc(50% - 3px)}.nopic{color:#999;font-size:12px}
.about h2{font-size:15px;margin:0;word-break:break-all}.about p{margin:.25em 0}
.times summary{cursor:pointer}.times ol{margin:.2em 0;padding-left:1.5em;columns:2}
.badge{font-size:12px;font-weight:600;color:#363}.failed .badge{color:#a11}.low .badge{color:#850}
.what,.times{color:#555;font-size:12px}.part{font-size:12px;color:#555;margin-right:.3em}
.part.weak{color:#a11;font-weight:600}.error{color:#a11;font-family:ui-monospace,monospace;font-size:12px;
word-break:break-word}
"""

# Filtering hides cards (hidden) and counts them; sorting moves them. ?q= and ?sort= in the address set both.
_SCRIPT = """
(() => {
const list = document.getElementById('cards'), box = document.getElementById('filter');
const menu = document.getElementById('sort'), shown = document.getElementById('shown');
const cards = Array.from(list.children);
const by = {
  review: (a, b) => a.dataset.rank - b.dataset.rank,
  name: (a, b) => a.dataset.name.localeCompare(b.dataset.name),
  confidence: (a, b) => a.dataset.confidence - b.dataset.confidence || a.dataset.rank - b.dataset.rank,
  time: (a, b) => b.dataset.seconds - a.dataset.seconds || a.dataset.rank - b.dataset.rank,
};
function filter() {
  const words = box.value.toLowerCase().split(/\\s+/).filter(Boolean);
  let count = 0;
  for (const card of cards) {
    const hit = words.every(w => card.dataset.text.includes(w));
    card.hidden = !hit;
    count += hit;
  }
  shown.textContent = count + ' of ' + cards.length;
}
function sort() {
  list.append(...cards.slice().sort(by[menu.value] || by.review));
}
const query = new URLSearchParams(location.search);
if (query.has('q')) box.value = query.get('q');
if (by[query.get('sort')]) menu.value = query.get('sort');
box.addEventListener('input', filter);
menu.addEventListener('change', sort);
sort();
filter();
})();
"""
