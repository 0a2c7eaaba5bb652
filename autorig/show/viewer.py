"""The review page's 3D view (``autorig batch --html``): each rig turned, zoomed, moved and marked in the browser.

    from autorig.show.viewer import install_three, rig_views, viewer_markup
    name = install_three(page_dir)                       # three.js, once, beside the page
    views, blobs = rig_views(assets, output_dir, input_dir, page_dir)
    html = viewer_markup(views, blobs, name)             # the viewer's dialog, data and scripts, for the page

One WebGL view serves the whole page: a card's "3D" button opens its rig in it (``web/viewer.js``). The view
draws the mesh with the skeleton over it, turns and zooms (three.js's OrbitControls), colours the mesh by the
weights of a picked joint, moves the rig (every bone bent in turn, computed in the page from the skeleton), and
lets the reviewer place the template's markers by clicking the surface and download ``<asset stem>.markers.json``
for ``autorig batch`` to pick up beside the asset.

**three.js** (``web/three-0.187.0.min.js``, MIT, ``web/three-LICENSE``; made again and checked byte for byte by
``python data/vendor_three.py``) is copied beside the page once, whatever the number of rigs: a classic script,
since Chromium runs neither ES modules nor ``fetch`` for pages opened from disk (file://).

**The rigs' bytes.** The page reads each rig's own ``.glb`` (or ``.gltf``) file. Opened from disk, Chromium
refuses that read, so the rigs are inlined too (base64) while their total stays within ``INLINE_BUDGET``, in
review order (failed, then doubtful rigs first: those a reviewer opens). A rig left out is fetched beside the page
when the page is served over http; from disk, the page asks once for the output folder (a folder picker) and reads
the rigs from it.

**Coordinates.** autorig's ``.glb`` keeps the input's vertices as they were read (the file's own axes and units;
a glTF input's scene flattened): the only transform between the file and the view is the turn that stands the rig
up, the rows of ``frame_rotation(up, front)``, recorded per rig as ``frame`` in the page's data. The view shows
``frame . p``; a clicked point ``q`` goes back to the input's coordinates as ``frame^T . q`` (a rotation), so the
markers file is in the input's own coordinates and units.
"""
from __future__ import annotations

import base64
import json
import math
import os
from pathlib import Path

from ..input.mesh import frame_rotation

__all__ = ["INLINE_BUDGET", "THREE_FILE", "install_three", "rig_views", "viewer_markup", "given_markers"]

WEB = Path(__file__).resolve().parent / "web"
THREE_VERSION = "0.187.0"
THREE_FILE = f"three-{THREE_VERSION}.min.js"
THREE_LICENSE = f"three-{THREE_VERSION}.LICENSE.txt"   # beside the page
INLINE_BUDGET = 8 << 20          # bytes of rigs inlined into one page (as base64: 4/3 of it)
MOTION_FPS = 30                  # a BVH motion is sampled at most this often for the page
DRIVEN_SHARE = 0.5               # a motion driving fewer of a rig's joints (tips aside) is not offered for it
VIEWABLE = (".glb", ".gltf")
MAX_MARKERS_BYTES = 1 << 20      # a markers file beside an asset larger than this is not shown on the page


def install_three(page_dir: str | os.PathLike) -> str:
    """Copy three.js (and its licence) into ``page_dir`` unless an identical copy is there; the script's name."""
    from ..exchange import write_file_atomic
    for source, name in ((WEB / THREE_FILE, THREE_FILE), (WEB / "three-LICENSE", THREE_LICENSE)):
        data = source.read_bytes()
        target = Path(page_dir) / name
        try:
            same = target.is_file() and not target.is_symlink() and target.read_bytes() == data
        except OSError:
            same = False
        if not same:
            write_file_atomic(target, data)
    return THREE_FILE


def markers_file_name(asset_input: str) -> str:
    """``<asset stem>.markers.json``: the markers file ``autorig batch`` picks up beside the asset."""
    return f"{Path(asset_input).stem}.markers.json"


def given_markers(folder: Path, name: str, root: Path) -> dict[str, list[float]]:
    """The markers in the file ``name`` in ``folder`` (a JSON object of names to [x, y, z]) that the page can
    show; {} when it is missing, unreadable, not a regular file, larger than ``MAX_MARKERS_BYTES`` or (through
    a symlink) outside ``root``, the input folder. The batch itself reports a bad markers file."""
    from ..input.confine import Refused, inside
    from ..input.limits import read_regular
    try:
        document = json.loads(read_regular(inside(folder, name, root), MAX_MARKERS_BYTES))
    except (OSError, ValueError, Refused, RecursionError):
        return {}
    if not isinstance(document, dict):
        return {}
    return {str(name): [float(c) for c in point] for name, point in document.items()
            if isinstance(point, list) and len(point) == 3
            and all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in point)}


def _marker_set(template: str) -> tuple[list[str], list[str] | None] | None:
    """(the template's marker set, its other joint names) as ``autorig.markers`` accepts them in a markers file
    (the page offers the set first, the joints after it: the template's names, whatever names the rig was
    written with); ([], None) for a template it cannot load here (the page then offers the rig's joint names);
    None when markers do not apply (the template-free skeleton, the user's own skeleton)."""
    from ..errors import AutorigError
    from ..markers import accepted_names, marker_names
    if template == "auto" or template.startswith("skeleton "):
        return None
    try:
        own = marker_names(template)
        return own, [name for name in accepted_names(template) if name not in own]
    except (AutorigError, OSError):
        return [], None


def _on_the_surface(names: list[str]) -> list[str]:
    """The markers among ``names`` that are points on the surface (the chin, the groin, the withers: they hold
    only part of a joint's place); the others are joints, placed in the middle of the limb under the click."""
    from ..markers import marker_of
    return [name for name in names if marker_of(name).joint != name]


def motion_track(rig_file: Path, motion, name: str) -> dict | None:
    """``motion`` (a BVH ``Motion``) retargeted onto the rig in ``rig_file`` as ``autorig pose`` does
    (``autorig.show.pose.retarget``, by joint names), for the page: name, fps, frames, joints (the names of the
    joints it turns), rotations (base64 of float32 [frames, joints, 4]: each joint's local rotation, x y z w, the
    glTF node's), root and translations (base64 of float32 [frames, 3]: the root's position, in place: its rise
    and fall kept, its travel over the ground left out, so the rig stays in view). Sampled at most
    ``MOTION_FPS`` times a second. None when the rig cannot take it (its root unmapped, or fewer than
    ``DRIVEN_SHARE`` of its joints driven)."""
    import numpy as np

    from ..errors import AutorigError
    from ..exchange.animated_gltf import quaternions
    from ..exchange.gltf import read_glb
    from .pose import retarget
    try:
        rig = read_glb(rig_file)
        animation = retarget(rig, motion)
    except AutorigError:
        return None
    tips = np.array([n.endswith("_end") for n in rig.names])
    moving = animation.animated
    if not (~tips).any() or moving[~tips].mean() < DRIVEN_SHARE:
        return None
    step = max(1, round(1 / (motion.frame_time * MOTION_FPS))) if motion.frame_time > 0 else 1
    rotations = quaternions(animation.local)[::step][:, moving]
    root = int(np.flatnonzero(np.asarray(rig.parents) < 0)[0])
    up = frame_rotation(rig.info.get("up", "y"), rig.info.get("front", "z"))[1]
    rest = np.asarray(rig.joints[root], dtype=np.float64)
    rise = (animation.positions[::step, root] - rest) @ up
    translations = rest + rise[:, None] * up

    def packed(array) -> str:
        return base64.b64encode(np.ascontiguousarray(array, dtype="<f4").tobytes()).decode("ascii")

    return {"name": name, "fps": 1 / (motion.frame_time * step) if motion.frame_time > 0 else float(MOTION_FPS),
            "frames": len(rotations), "joints": [n for n, m in zip(rig.names, moving) if m],
            "rotations": packed(rotations), "root": rig.names[root], "translations": packed(translations)}


def rig_views(assets, output_dir: Path, input_dir: Path, page_dir: Path, budget: int | None = None,
              motion=None, motion_name: str = "motion") -> tuple[list[dict | None], dict[str, str]]:
    """For each of ``assets`` (``AssetResult``, in the page's order): the 3D view's data, or None for an asset
    without a rig it can show; and {element id: base64} of the rigs inlined, in that order while their total
    stays within ``budget`` bytes (default ``INLINE_BUDGET``).

    A view's data: name (the asset's input path), output (the rig's path in the output folder), href (the rig
    relative to the page), inline (the id of its inlined bytes, or None), frame (3 rows: the input's directions
    of the view's x, y, z), template (None where markers do not apply), markers (the template's marker set),
    joints (the template's other names a markers file accepts, or None: the rig's own joint names then),
    surface (those of them placed on the surface; the others, joints, in the middle of the limb),
    markers_file (``<asset stem>.markers.json``), beside (the asset's folder in the input folder) and given
    (the markers already in that file beside the asset, in input coordinates); with ``motion`` (a BVH
    ``Motion`` called ``motion_name``), motion: its ``motion_track`` for that rig (None where it does not apply).
    """
    from urllib.parse import quote
    views: list[dict | None] = []
    blobs: dict[str, str] = {}
    left = INLINE_BUDGET if budget is None else budget
    for asset in assets:
        rig = Path(output_dir) / asset.output
        if asset.failed or rig.suffix.lower() not in VIEWABLE or not rig.is_file():
            views.append(None)
            continue
        href = Path(os.path.relpath(os.path.abspath(rig), page_dir)).as_posix()
        accepted = _marker_set(asset.template)
        markers, joints = accepted if accepted is not None else (None, None)
        inline = None
        size = rig.stat().st_size
        if size <= left:
            inline = f"rig-{len(views)}"
            blobs[inline] = base64.b64encode(rig.read_bytes()).decode("ascii")
            left -= size
        frame = (frame_rotation(asset.up, asset.front).tolist()
                 if asset.up and asset.front and "auto" not in (asset.up, asset.front) else None)
        source = Path(input_dir) / asset.input
        views.append({
            "name": asset.input, "output": asset.output, "href": quote(href, errors="surrogateescape"),
            "inline": inline, "frame": frame, "template": None if markers is None else asset.template,
            "markers": markers or [], "joints": joints, "surface": _on_the_surface(markers or []),
            "markers_file": markers_file_name(asset.input),
            "beside": Path(asset.input).parent.as_posix(),
            "given": given_markers(source.parent, markers_file_name(asset.input), Path(input_dir))
            if markers is not None else {},
            "motion": motion_track(rig, motion, motion_name) if motion is not None else None})
    return views, blobs


def _json_in_html(value) -> str:
    """JSON that can sit inside a <script> element: no '<', '>' or '&' left to end it."""
    text = json.dumps(value, separators=(",", ":"))
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def viewer_markup(views: list[dict | None], blobs: dict[str, str], three: str) -> str:
    """The page's viewer: its dialog, its data (views and inlined rigs) and its scripts, to end the <body>."""
    from html import escape
    data = "".join(f'<script type="application/octet-stream" id="{key}">{value}</script>\n'
                   for key, value in blobs.items())
    return (_DIALOG + f'<script type="application/json" id="views">{_json_in_html(views)}</script>\n' + data +
            f'<script src="{escape(three)}"></script>\n<script>{(WEB / "viewer.js").read_text(encoding="utf-8")}'
            '</script>')


def viewer_button(index: int) -> str:
    """The card's button that opens its rig in the 3D view."""
    return f'<button type="button" class="view3d" data-view="{index}">3D view</button>'


VIEWER_STYLE = """
.view3d{margin:.3em 0;padding:.2em .8em;cursor:pointer}
#viewer{width:min(96vw,1200px);max-height:96vh;padding:0;border:1px solid #888;border-radius:6px}
#viewer::backdrop{background:#0008}
.vbar{display:flex;flex-wrap:wrap;gap:.4em .8em;align-items:center;padding:.4em .6em;background:#eee;font-size:13px}
.vbar h2{font-size:15px;margin:0;flex:1 1 auto;word-break:break-all}
.vbody{display:flex;gap:0}#view-canvas{width:min(70vw,860px);height:min(72vh,640px);display:block;
touch-action:none;cursor:crosshair}.vside{flex:1;padding:.5em;font-size:12px;overflow:auto;max-height:min(72vh,640px)}
.vside ol{padding-left:1.3em;margin:.3em 0}.vside li button{font-size:11px;margin-left:.3em}
#view-status{color:#a11;min-height:1.2em;padding:.2em .6em;font-size:12px}
"""

_DIALOG = """<dialog id="viewer" data-state="closed"><div class="vbar"><h2 id="view-title"></h2>
<label>weights of <select id="view-joint" aria-label="weights of a joint"></select></label>
<label>motion <select id="view-motion" aria-label="motion"></select></label>
<button type="button" id="view-move">move</button><button type="button" id="view-close">close</button></div>
<div class="vbody"><canvas id="view-canvas" aria-label="the rig in 3D: drag to turn, wheel to zoom"></canvas>
<div class="vside"><p>Drag to turn, right-drag to pan, wheel to zoom.</p>
<div id="view-marker-box"><p><b>Markers</b>: pick one, click the surface; the next is picked for you.</p>
<select id="view-marker" aria-label="marker"></select><ol id="view-markers"></ol>
<button type="button" id="view-download" disabled>download</button>
<button type="button" id="view-clear">clear</button>
<p>Save the file beside the asset and run the batch again: it rigs that asset with them.</p></div>
<p id="view-folder-box" hidden><label>output folder <input type="file" id="view-folder" webkitdirectory>
</label></p></div></div><p id="view-status"></p></dialog>
"""
