"""A picture of a rig: front and side views of the mesh coloured by dominant joint, the skeleton drawn over it
(for a flat shape, a top view and the wider of the two).

    from autorig.show.preview import render_preview
    render_preview(rig, "hero.png")                  # the rig's own up/front (rig.info), else +y up, facing +z

The views are orthographic and in the character's own frame (``autorig.input.mesh.frame_rotation(up, front)``):
the front view looks at its face, so its left is on the picture's right; the side view looks at its right side,
so it faces the picture's right. Faces are shaded from the camera and painted far to near; the skeleton is
drawn on top of the mesh, as if seen through it (bones black, joints red, tips grey), with each weight-carrying
joint labelled (in the side view only the near, right side and the middle). Labels never overlap one another,
the titles or the legend, and stay inside their view: each is measured (its text's extent) and put beside its
joint, outward first, else moved up or down with a leader line to its dot, else inward; one that finds no room
is left out (the dense fingers of a hand seen from the side). The legend lists the joints that are some
vertex's strongest influence, in the colours the mesh uses. A dense mesh is drawn simplified to about
``PREVIEW_FACES`` triangles (``simplified``): at the picture's size the rest cannot be seen, and painting 97k
triangles twice took longer than rigging them.

Needs matplotlib (``pip install 'autorig[preview]'``); it is imported only when a picture is drawn.
"""
from __future__ import annotations

import os
from io import BytesIO

import numpy as np

from ..input.mesh import frame_rotation
from ..result import Rig

__all__ = ["render_preview", "draw_preview", "simplified"]

_VIEW_HEIGHT = 7.0   # inches (at 100 dpi) of each view's drawing area
_MAX_VIEWS_WIDTH = 16.0  # inches for both views together
_LEGEND_WIDTH = 2.3  # inches per column, at least
_LEGEND_SIZE = 8.5   # points
_LEGEND_ROW = 0.24   # inches per entry
_DPI = 100
_LABEL_SIZE = 7.5  # points
PREVIEW_FACES = 20_000   # a denser mesh is drawn simplified to about this many triangles
# Where a label may go, in points from its joint: beside it, then further up and down with a leader line.
_LABEL_OFFSETS = [(6, 0)] + [(dx, sign * dy) for dy in range(9, 82, 9) for sign in (1, -1) for dx in (10, 28, 46)]


def render_preview(rig: Rig, path: str | os.PathLike, title: str | None = None, up: str | None = None,
                   front: str | None = None) -> dict[str, tuple[int, int, int, int]]:
    """Draw ``rig`` to the PNG file ``path`` (written atomically).

    up, front  the rig's axes (x|y|z|-x|-y|-z); default ``rig.info``'s ``up``/``front``, else y and z
    title      the heading; default names the template and counts joints and vertices
    returns    {"front": box, "side": box}: where each view is in the picture, as pixel (left, top, right,
               bottom), origin top-left; a flat shape (lower than 0.6 of its narrower horizontal extent: a
               spider, a star lying down) is seen from above instead, {"top": box, "front" or "side": box}
    Raises ``ImportError`` without matplotlib, ``OutputError`` if ``path`` cannot be written.
    """
    from matplotlib.image import imsave

    from ..exchange import write_file_atomic

    figure, boxes = draw_preview(rig, title, up, front)
    buffer = BytesIO()
    # The canvas was drawn once to place the labels; its pixels are the picture (savefig would draw it again).
    imsave(buffer, np.asarray(figure.canvas.buffer_rgba()), format="png", dpi=_DPI)
    write_file_atomic(path, buffer.getvalue())
    return boxes


def draw_preview(rig: Rig, title: str | None = None, up: str | None = None, front: str | None = None):
    """(figure, boxes): ``render_preview``'s picture as a drawn matplotlib Figure (its joint labels are the
    texts whose gid is "joint label") and the views' pixel boxes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    frame = frame_rotation(up or rig.info.get("up", "y"), front or rig.info.get("front", "z"))
    vertices = np.asarray(rig.vertices, dtype=np.float64) @ frame.T   # columns: left, up, front
    joints = np.asarray(rig.joints, dtype=np.float64) @ frame.T
    faces = np.asarray(rig.faces, dtype=np.int64)
    weights = np.asarray(rig.weights, dtype=np.float64)
    colours = joint_colours(len(rig.names))
    face_joint = np.argmax(weights[faces].sum(axis=1), axis=1)   # [F] the joint with most weight on the face
    shown = np.unique(face_joint)
    if len(faces) > PREVIEW_FACES:
        vertices, faces, face_joint = simplified(vertices, faces, face_joint, PREVIEW_FACES,
                                                 int(_VIEW_HEIGHT * _DPI))

    views = choose_views(vertices)
    # One scale for both views, so that the taller one (the top view of a flat shape) fills the height.
    tallest = max(max(float(np.ptp(vertices @ y)) for _, _, _, y, _ in views), 1e-12)
    natural = [_VIEW_HEIGHT * 1.15 * float(np.ptp(vertices @ x)) / tallest for _, _, x, _, _ in views]
    # Long, low shapes would make a very wide picture: shrink both views to fit the width instead.
    shrink = min(1.0, _MAX_VIEWS_WIDTH / sum(natural))
    view_height = max(_VIEW_HEIGHT * shrink, 2.5)
    widths = [max(3.0, w * shrink) for w in natural]
    legend_columns = int(np.ceil(len(shown) / max(1, int((view_height - 0.4) / _LEGEND_ROW))))
    legend_width = _legend_column_width([rig.names[j] for j in shown]) * legend_columns
    figure = Figure(figsize=(sum(widths) + legend_width, view_height + 0.9), dpi=_DPI)
    FigureCanvasAgg(figure)  # drawn with Agg directly, not through pyplot: the caller's backend stays as it was
    grid = figure.add_gridspec(1, 3, width_ratios=widths + [legend_width], left=0.01, right=0.99, bottom=0.02,
                               top=1 - 0.8 / (view_height + 0.9), wspace=0.04)
    heading = figure.suptitle(title if title is not None else
                              f"{rig.template or 'rig'}: {len(rig.names)} joints, {len(rig.vertices)} vertices",
                              fontsize=14, fontweight="bold")

    axes, labels = {}, []
    for column, (name, view_title, screen_x, screen_y, toward_camera) in enumerate(views):
        ax = figure.add_subplot(grid[0, column])
        labels.append(_draw_view(ax, vertices, faces, face_joint, colours, joints, rig, screen_x, toward_camera,
                                 screen_y))
        ax.set_title(view_title, fontsize=11)
        axes[name] = ax
    legend = _draw_legend(figure.add_subplot(grid[0, 2]), rig.names, colours, shown, legend_columns)

    renderer = figure.canvas.get_renderer()
    taken = [heading.get_window_extent(renderer), legend.get_window_extent(renderer),
             *(ax.title.get_window_extent(renderer) for ax in axes.values())]
    for ax, drawn in zip(axes.values(), labels):
        _label_joints(ax, *drawn, rig.names, renderer, taken)
    figure.canvas.draw()
    pixel_height = figure.canvas.get_width_height()[1]
    boxes = {}
    for name, ax in axes.items():
        box = ax.get_window_extent()
        boxes[name] = (int(box.x0), int(pixel_height - box.y1), int(box.x1), int(pixel_height - box.y0))
    return figure, boxes


def simplified(vertices: np.ndarray, faces: np.ndarray, face_joint: np.ndarray, count: int, cells: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mesh (vertices [V, 3], faces [F, 3]) simplified to about ``count`` faces, each new face taking the
    joint (``face_joint`` [F]) of the original face whose centre is nearest its own: (vertices [V', 3],
    faces [F', 3], face_joint [F']). For the pictures (this preview and ``autorig.show.thumbnails``).

    First vertex clustering on a grid of ``cells`` along the longest side (one cell per output pixel: what it
    merges is not visible, and it is one np.unique, ~10 ms at 100k faces), then quadric decimation
    (fast-simplification, as the pipeline's coarse mesh) of what is left: decimating 100k faces directly cost
    0.1-0.2 s, most of a large asset's thumbnails.
    """
    import fast_simplification
    from scipy.spatial import cKDTree

    low = vertices.min(axis=0)
    cell = max(float(np.ptp(vertices, axis=0).max()) / cells, 1e-300)
    grid = np.floor((vertices - low) / cell).astype(np.int64)                  # [V, 3] in 0..cells
    key = (grid[:, 0] * (cells + 1) + grid[:, 1]) * (cells + 1) + grid[:, 2]
    _, first, cluster = np.unique(key, return_index=True, return_inverse=True)
    faces = cluster.reshape(-1)[faces]
    kept = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    vertices, faces, face_joint = vertices[first], faces[kept], face_joint[kept]
    if len(faces) <= count:
        return vertices, faces, face_joint
    coarse_vertices, coarse_faces = fast_simplification.simplify(vertices, faces.astype(np.int32),
                                                                 target_count=count)
    coarse_vertices = np.asarray(coarse_vertices, dtype=np.float64)
    coarse_faces = np.asarray(coarse_faces, dtype=np.int64)
    _, nearest = cKDTree(vertices[faces].mean(axis=1)).query(coarse_vertices[coarse_faces].mean(axis=1))
    return coarse_vertices, coarse_faces, face_joint[nearest]


# Each view: (name, heading, screen x axis, screen y axis, axis pointing at the camera) in the character's
# frame (left, up, front).
_FRONT = ("front", "front", np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
_SIDE = ("side", "side (right)", np.array([0, 0, 1.0]), np.array([0, 1.0, 0]), np.array([-1.0, 0, 0]))
_TOP = ("top", "top (front up)", np.array([-1.0, 0, 0]), np.array([0, 0, 1.0]), np.array([0, 1.0, 0]))
_FLAT = 0.6   # a shape lower than this share of its narrower horizontal extent is flat: seen from above


def choose_views(vertices: np.ndarray) -> list[tuple]:
    """The two views to draw of vertices [V, 3] (character's frame): front and side; for a flat shape (a
    spider, a star lying down), whose limbs would overlap in both, the top view and the wider of the two."""
    left, up, front = np.ptp(vertices, axis=0)
    if up < _FLAT * min(left, front):
        return [_TOP, _FRONT if left >= front else _SIDE]
    return [_FRONT, _SIDE]


def _draw_view(ax, vertices, faces, face_joint, colours, joints, rig: Rig, screen_x, toward_camera,
               up=np.array([0.0, 1.0, 0.0])) -> tuple[np.ndarray, np.ndarray, bool, np.ndarray]:
    """One orthographic view: shaded faces far to near, then bones and joints over them. Returns what its
    labels need (``_label_joints``): the joints on screen [J, 2], their depth towards the camera [J], whether
    it is a side view, and which joints are tips [J].

    vertices [V, 3], joints [J, 3]  in the character's frame (left, up, front)
    faces [F, 3], face_joint [F]    triangles and the joint whose colour (colours [J, 3]) each one takes
    screen_x, toward_camera, up [3] the frame directions drawn rightwards, pointing at the viewer and upwards
    """
    from matplotlib import patheffects
    from matplotlib.collections import LineCollection, PolyCollection

    screen = np.stack([vertices @ screen_x, vertices @ up], axis=1)        # [V, 2]
    corners = vertices[faces]                                              # [F, 3, 3]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1)
    facing = np.abs(normals @ toward_camera) / np.where(length > 0, length, 1.0)
    # Faces are lit from the camera whichever way they are wound: inward-facing parts still read as solid.
    shade = 0.35 + 0.65 * facing
    order = np.argsort(corners.mean(axis=1) @ toward_camera, kind="stable")
    face_colours = colours[face_joint[order]] * shade[order, None]
    ax.add_collection(PolyCollection(screen[faces[order]], facecolors=face_colours, edgecolors="none",
                                     antialiaseds=False, rasterized=True))

    joint_screen = np.stack([joints @ screen_x, joints @ up], axis=1)
    bones = [(joint_screen[p], joint_screen[j]) for p, j in rig.bones]
    halo = [patheffects.withStroke(linewidth=4.5, foreground="white")]
    ax.add_collection(LineCollection(bones, colors="black", linewidths=2.0, path_effects=halo, zorder=3))
    # Tips: joints with no child (a chain's end: autorig's *_end, Mixamo's HeadTop_End and finger 4s).
    tips = ~np.isin(np.arange(len(rig.names)), np.asarray(rig.parents))
    ax.scatter(*joint_screen[~tips].T, s=36, c="red", edgecolors="black", linewidths=0.8, zorder=4)
    ax.scatter(*joint_screen[tips].T, s=14, c="0.6", edgecolors="black", linewidths=0.6, zorder=4)

    ax.set_aspect("equal")
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    pad = 0.04 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_xticks([])
    ax.set_yticks([])
    for spine in ax.spines.values():
        spine.set_color("0.85")
    ax.apply_aspect()  # fixes the axes box now, so data -> pixel positions below are final
    return joint_screen, joints @ toward_camera, toward_camera[0] != 0, tips


def _label_joints(ax, joint_screen: np.ndarray, depth: np.ndarray, side: bool, tips: np.ndarray,
                  names: list[str], renderer, taken: list) -> None:
    """Name each weight-carrying joint (not the tips), parents first, where its label's measured box fits inside
    the view and overlaps nothing in ``taken`` (pixel boxes of the labels placed so far, in both views, and of
    the titles and legend; each label placed is added): beside its dot, outward from the body's middle, then
    further up or down with a leader line, then the same inward; else it is left out. The side view labels
    only the camera's side and the middle (both sides fall on one another there)."""
    from matplotlib import patheffects
    from matplotlib.text import Text

    halo = [patheffects.withStroke(linewidth=2.5, foreground="white")]
    leader = {"arrowstyle": "-", "color": "0.3", "linewidth": 0.6, "shrinkA": 0, "shrinkB": 3}
    pixels = ax.transData.transform(joint_screen)
    view = ax.get_window_extent(renderer)
    centre = float(np.median(pixels[:, 0]))
    near_side = float(np.median(depth)) - 0.02 * max(float(np.ptp(depth)), 1e-12)
    points = _DPI / 72
    probe = Text(0, 0, "", fontsize=_LABEL_SIZE, figure=ax.figure)
    for j, name in enumerate(names):
        if tips[j] or (side and depth[j] < near_side):
            continue
        probe.set_text(name)
        extent = probe.get_window_extent(renderer)
        width, height = extent.width, extent.height
        x, y = pixels[j]
        outward = 1 if x >= centre else -1
        for direction in (outward, -outward):
            spot = next(((dx, dy) for dx, dy in _LABEL_OFFSETS
                         if _fits(x + direction * dx * points, y + dy * points, width, height, direction, view,
                                  taken)), None)
            if spot is not None:
                break
        if spot is None:
            continue
        dx, dy = spot
        label = ax.annotate(name, joint_screen[j], xytext=(direction * dx, dy), textcoords="offset points",
                            ha="left" if direction > 0 else "right", va="center", fontsize=_LABEL_SIZE,
                            path_effects=halo, zorder=5, gid="joint label",
                            arrowprops=leader if (dx, dy) != _LABEL_OFFSETS[0] else None)
        label.update_positions(renderer)     # an annotation's offset is resolved only when drawn
        taken.append(Text.get_window_extent(label, renderer))


def _fits(x: float, y: float, width: float, height: float, direction: int, view, taken: list) -> bool:
    """Whether a label of ``width`` x ``height`` pixels anchored at (x, y) (its left end when ``direction`` is
    1, its right end when -1; centred on y) lies inside the box ``view`` and off every box in ``taken``
    (with a pixel to spare)."""
    x0, x1 = (x, x + width) if direction > 0 else (x - width, x)
    y0, y1 = y - height / 2, y + height / 2
    if x0 < view.x0 + 1 or x1 > view.x1 - 1 or y0 < view.y0 + 1 or y1 > view.y1 - 1:
        return False
    return not any(x0 < b.x1 + 1 and b.x0 - 1 < x1 and y0 < b.y1 + 1 and b.y0 - 1 < y1 for b in taken)


def _legend_column_width(names: list[str]) -> float:
    """Inches a legend column needs for the longest of ``names``: its text measured, plus the swatch and the
    spaces around it (about 5 em; Mixamo's long finger names need more than the default)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    font = FontProperties(size=_LEGEND_SIZE)
    longest = max((TextToPath().get_text_width_height_descent(name, font, ismath=False)[0] for name in names),
                  default=0.0)
    return max(_LEGEND_WIDTH, (longest + 5.5 * _LEGEND_SIZE) / 72)


def _draw_legend(ax, names: list[str], colours: np.ndarray, shown: np.ndarray, columns: int):
    """The legend: one swatch per joint that colours some face, in ``columns`` columns."""
    from matplotlib.patches import Patch

    ax.axis("off")
    handles = [Patch(facecolor=colours[j], edgecolor="0.3", label=names[j]) for j in shown]
    return ax.legend(handles=handles, loc="upper left", fontsize=_LEGEND_SIZE, title="strongest joint",
                     title_fontsize=9, frameon=False, ncols=columns)


# matplotlib's tab20 (strong hues, then their pale versions), tab20b and tab20c: written out so that drawing a
# thumbnail does not import matplotlib (~0.3 s a process) for its colour tables.
_TAB20 = ("1f77b4 aec7e8 ff7f0e ffbb78 2ca02c 98df8a d62728 ff9896 9467bd c5b0d5 8c564b c49c94 e377c2 f7b6d2 7f7f7f "
          "c7c7c7 bcbd22 dbdb8d 17becf 9edae5").split()
_TAB20B = ("393b79 5254a3 6b6ecf 9c9ede 637939 8ca252 b5cf6b cedb9c 8c6d31 bd9e39 e7ba52 e7cb94 843c39 ad494a d6616b "
           "e7969c 7b4173 a55194 ce6dbd de9ed6").split()
_TAB20C = ("3182bd 6baed6 9ecae1 c6dbef e6550d fd8d3c fdae6b fdd0a2 31a354 74c476 a1d99b c7e9c0 756bb1 9e9ac8 bcbddc "
           "dadaeb 636363 969696 bdbdbd d9d9d9").split()
# The first ten joints (the trunk and one side of a skeleton, parents first) never share a hue.
_PALETTE = np.array([[int(h[i:i + 2], 16) for i in (0, 2, 4)]
                     for h in _TAB20[0::2] + _TAB20[1::2] + _TAB20B + _TAB20C]) / 255.0


def joint_colours(count: int) -> np.ndarray:
    """[count, 3] RGB colours in 0-1, neighbouring indices far apart in hue and lightness."""
    return _PALETTE[np.arange(count) % len(_PALETTE)]
