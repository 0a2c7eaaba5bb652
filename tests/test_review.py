"""The batch review page (autorig batch --html, autorig.batch.review), checked as a file and in headless Chromium.

One small batch is rigged once per module: a low-resolution mannequin (a good rig), a cylinder rigged as a
biped (a rig of low confidence) under a name full of HTML's special characters, and a text file called
bad.obj (a failure). Its reports and page go inside the output folder, which does not exist before the run.
"""
from __future__ import annotations

import html
import json
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pytest
from chromium import EXECUTABLE, Chromium
from click.testing import CliRunner

from autorig import samples
from autorig.batch import EXIT_SOME_FAILED, THUMBNAILS_FOLDER
from autorig.cli import cli

pytest.importorskip("PIL", reason="the preview extra (Pillow) is not installed")
from PIL import Image  # noqa: E402

AXES = ["--up", "y", "--front", "z"]
TUBE = "odd & <tube>.obj"
needs_chromium = pytest.mark.skipif(EXECUTABLE is None, reason="chromium is not installed (apt-get install chromium)")


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="autorig")


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist()]
    path.write_text("".join(lines + [f"f {a} {b} {c}\n" for a, b, c in (faces + 1).tolist()]))


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """(input folder, output folder, CLI result, page path) of one batch written with --html."""
    import trimesh

    root = tmp_path_factory.mktemp("review")
    assets = root / "assets"
    # Arms down a little, as the corpus the biped learned from holds them: a rig with no weak part. (A T-pose
    # is rigged as well, but its arms are far from the learned rest directions, and its fit shows that.)
    hero = samples.mannequin(pose="a", resolution=56)
    write_obj(assets / "hero.obj", hero.vertices, hero.faces)
    tube = trimesh.creation.cylinder(radius=0.15, height=1.7, sections=24)
    tube.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))  # standing along +y
    write_obj(assets / "props" / TUBE, tube.vertices, tube.faces)
    (assets / "sub").mkdir()
    (assets / "sub" / "bad.obj").write_text("this is not a mesh\n")
    out = root / "rigged"
    page = out / "pages" / "review.html"
    result = run("batch", assets, "-o", out, *AXES, "-j", "2", "--html", page,
                 "--report", out / "report.json", "--junit", out / "reports" / "junit.xml")
    return assets, out, result, page


class Cards(HTMLParser):
    """The page's cards (data-* attributes, links, images) and every URL it names, read as a browser would."""

    def __init__(self, text: str):
        super().__init__()
        self.cards: list[dict] = []
        self.urls: list[str] = []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "article":
            self.cards.append({**attrs, "links": [], "images": []})
            self.in_card = True
        for key in ("src", "href", "action", "poster", "srcset"):
            if key in attrs:
                self.urls.append(attrs[key])
                if getattr(self, "in_card", False) and key in ("src", "href"):
                    self.cards[-1]["images" if key == "src" else "links"].append(attrs[key])

    def handle_endtag(self, tag):
        if tag == "article":
            self.in_card = False


def test_reports_and_page_inside_the_output_folder_before_it_exists(batch):
    assets, out, result, page = batch
    assert result.exit_code == EXIT_SOME_FAILED, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["summary"]["failed"] == 1 and (out / "reports" / "junit.xml").is_file() and page.is_file()
    # A report in a missing folder outside the output folder is still refused, before any rigging.
    missing = run("batch", assets, "-o", out.parent / "elsewhere", *AXES, "--html", out.parent / "nope" / "r.html")
    assert missing.exit_code == 4 and "the directory" in missing.output and "does not exist" in missing.output
    assert not (out.parent / "elsewhere").exists()


def test_page_is_offline_doubtful_first_and_links_the_rigs(batch):
    assets, out, result, page = batch
    text = page.read_text(encoding="utf-8")
    parsed = Cards(text)
    assert [c["data-name"] for c in parsed.cards] == ["sub/bad.obj", f"props/{TUBE}", "hero.obj"]
    assert [c["class"] for c in parsed.cards] == ["card failed", "card low", "card ok"]
    assert "Content-Security-Policy" in text and "default-src 'none'" in text
    # Nothing to fetch: inline images, and links only to the rigs, relative to the page.
    assert all(u.startswith("data:image/webp;base64,") or not re.match(r"^([a-z]+:|//)", u) for u in parsed.urls)
    assert not re.search(r"url\(|@import|<link|<iframe|<object|<embed", text)
    bad, tube, hero = parsed.cards
    assert not bad["images"] and not bad["links"]
    for card, output in ((tube, "props/odd & <tube>.rigged.glb"), (hero, "hero.rigged.glb")):
        assert len(card["images"]) == 2 and all(i.startswith("data:image/webp") for i in card["images"])
        assert [(page.parent / unquote(link)).resolve() for link in card["links"]] == [(out / output).resolve()]
    assert "<tube>" not in text and "&lt;tube&gt;" in text  # the name is text, not markup
    thumbnails = sorted(p.relative_to(out).as_posix() for p in (out / THUMBNAILS_FOLDER).rglob("*.webp"))
    assert thumbnails == [f"{THUMBNAILS_FOLDER}/hero.rigged.glb.front.webp",
                          f"{THUMBNAILS_FOLDER}/hero.rigged.glb.side.webp",
                          f"{THUMBNAILS_FOLDER}/props/odd & <tube>.rigged.glb.front.webp",
                          f"{THUMBNAILS_FOLDER}/props/odd & <tube>.rigged.glb.side.webp"]
    for path in thumbnails:
        with Image.open(out / path) as picture:
            assert picture.format == "WEBP" and picture.height == 160 and picture.width >= 40
    report = {a["input"]: a for a in json.loads((out / "report.json").read_text())["assets"]}
    assert "thumbnails" in report["hero.obj"]["timings"]
    # The tube is no biped: some part of its confidence says so (which one, the fit or the limbs, depends on
    # which way up a cylinder is taken, a tie).
    tube_parts = report[f"props/{TUBE}"]["confidence_parts"]
    assert report[f"props/{TUBE}"]["confidence"] < 0.5 and min(tube_parts.values()) < 0.8
    # A doubtful rig is called so, with what pulled it down, in the report and on its card; the good one is not.
    assert report[f"props/{TUBE}"]["doubtful"] and report[f"props/{TUBE}"]["confidence_reasons"]
    assert not report["hero.obj"]["doubtful"]
    card = text[text.index(f'data-name="{html.escape(f"props/{TUBE}")}"'):]
    assert "probably wrong: " + html.escape(report[f"props/{TUBE}"]["confidence_reasons"][0]) in card


@needs_chromium
def test_page_in_chromium_cards_errors_pictures_filter_and_sort(batch, tmp_path):
    assets, out, result, page = batch
    with Chromium(width=1300, height=1000) as browser:
        browser.open(page)
        cards = browser.evaluate("Array.from(document.querySelectorAll('article'), a => "
                                 "({name: a.dataset.name, text: a.innerText, visible: a.offsetHeight > 0, "
                                 "weak: Array.from(a.querySelectorAll('.part.weak'), p => p.innerText), "
                                 "stages: Array.from(a.querySelectorAll('.times li'), li => li.textContent)}))")
        assert [c["name"] for c in cards] == ["sub/bad.obj", f"props/{TUBE}", "hero.obj"]
        assert all(c["visible"] for c in cards)
        assert "not an OBJ file" in cards[0]["text"] and "failed" in cards[0]["text"]
        assert "doubtful" in cards[1]["text"] and "probably wrong: " in cards[1]["text"]
        assert re.search(r"confidence 0\.\d\d\s+fit 0\.\d\d", cards[1]["text"])
        # what pulls it down: the weakest part of the report's confidence, marked on the card
        tube_parts = json.loads((out / "report.json").read_text())["assets"]
        tube_parts = next(a for a in tube_parts if a["input"] == f"props/{TUBE}")["confidence_parts"]
        weakest = min(tube_parts, key=tube_parts.get)
        assert any(w.startswith(weakest + " ") for w in cards[1]["weak"]) and not cards[2]["weak"]
        assert "biped · up y · front z" in cards[2]["text"] and re.search(r"\d\.\d s: \w", cards[2]["text"])
        assert {"load", "embedding", "skin weights", "write", "thumbnails"} <= {s.rsplit(" ", 1)[0]
                                                                                for s in cards[2]["stages"]}
        summary = browser.evaluate("document.querySelector('.summary').innerText")
        assert re.search(r"3\s+assets\s+2\s+ok\s+1\s+failed\s+0\s+skipped\s+1\s+doubtful", summary), summary
        widths = browser.evaluate("Promise.all(Array.from(document.images, i => i.decode().then(() => "
                                  "[i.naturalWidth, i.naturalHeight, i.width])))")
        assert len(widths) == 4 and all(w > 0 and h == 160 and shown > 0 for w, h, shown in widths)

        visible = "Array.from(document.querySelectorAll('article:not([hidden])'), a => a.dataset.name)"
        browser.type_into("#filter", "hero")
        assert browser.evaluate(visible) == ["hero.obj"]
        assert browser.evaluate("document.getElementById('shown').textContent") == "1 of 3"
        browser.type_into("#filter", "biped failed")  # every word: the failure, not the good biped
        assert browser.evaluate(visible) == ["sub/bad.obj"]
        browser.type_into("#filter", "")
        assert len(browser.evaluate(visible)) == 3
        browser.evaluate("(m => { m.value = 'name'; m.dispatchEvent(new Event('change')); })"
                         "(document.getElementById('sort'))")
        assert browser.evaluate(visible) == ["hero.obj", f"props/{TUBE}", "sub/bad.obj"]

        browser.open(page, query="q=tube&sort=time")  # the address fills the filter box
        assert browser.evaluate(visible) == [f"props/{TUBE}"]
        assert browser.evaluate("document.getElementById('filter').value") == "tube"
        browser.type_into("#filter", "")
        shot = browser.screenshot(tmp_path / "review.png")
        assert browser.console_messages() == []
    with Image.open(shot) as picture:
        assert picture.width == 1300 and picture.height >= 400
        colours = np.asarray(picture.convert("RGB"))[::2, ::2].reshape(-1, 3) // 32
        assert len(np.unique(colours, axis=0)) > 30  # text and the thumbnails' colours, not a blank page


def test_resumed_run_keeps_the_cards_and_pictures_of_skipped_assets(batch, tmp_path):
    assets, out, result, page = batch
    shutil.copytree(assets, tmp_path / "assets")
    shutil.copytree(out, tmp_path / "rigged")
    # This time the page comes from the input folder's autorig.toml, relative to the output folder.
    (tmp_path / "assets" / "autorig.toml").write_text('html = "again.html"\n')
    again = run("batch", tmp_path / "assets", "-o", tmp_path / "rigged", *AXES)
    assert again.exit_code == EXIT_SOME_FAILED and "3 assets unchanged" in again.stderr
    before, after = Cards(page.read_text()), Cards((tmp_path / "rigged" / "again.html").read_text())
    assert [c["data-name"] for c in after.cards] == [c["data-name"] for c in before.cards]
    assert [c["images"] for c in after.cards] == [c["images"] for c in before.cards]
    text = (tmp_path / "rigged" / "again.html").read_text()
    assert text.count("in the run that rigged it") == 2 and "not an OBJ file" in text
    assert text.count('class="part weak"') == page.read_text().count('class="part weak"') > 0
    assert re.search(r"<b>3</b>skipped", text)


def test_html_is_set_for_the_whole_batch_only(tmp_path):
    (tmp_path / "a" / "sub").mkdir(parents=True)
    (tmp_path / "a" / "sub" / "autorig.toml").write_text('html = "review.html"\n')
    (tmp_path / "a" / "sub" / "x.obj").write_text("v 0 0 0\n")
    result = run("batch", tmp_path / "a", "-o", tmp_path / "out")
    assert result.exit_code == 2 and "html is set for the whole batch" in result.output


def test_skipped_assets_without_pictures_say_why(batch, tmp_path):
    assets, out, result, page = batch
    shutil.copytree(out, tmp_path / "rigged")
    manifest_path = tmp_path / "rigged" / ".autorig-batch.json"
    manifest = json.loads(manifest_path.read_text())
    hero = manifest["assets"]["hero.obj"]
    del hero["thumbnails"], hero["timings"]["thumbnails"]  # as a run without --html leaves it
    manifest_path.write_text(json.dumps(manifest))
    again = run("batch", assets, "-o", tmp_path / "rigged", *AXES, "--html", tmp_path / "again.html")
    assert again.exit_code == EXIT_SOME_FAILED
    cards = {c["data-name"]: c for c in Cards((tmp_path / "again.html").read_text()).cards}
    assert not cards["hero.obj"]["images"] and len(cards[f"props/{TUBE}"]["images"]) == 2
    assert "no picture: rigged by a run without html (--force draws it)" in (tmp_path / "again.html").read_text()
