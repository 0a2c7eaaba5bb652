"""The review page's thumbnails (``autorig batch --html``), drawn with Pillow instead of matplotlib.

The same views as ``autorig.show.preview`` (front and side, or top and the wider of those for a flat shape; mesh
coloured by strongest joint, shaded from the camera and painted far to near, bones and joints over it), without
what a 160-pixel picture cannot show legibly (title, labels, legend). matplotlib took 0.2-0.4 s a view, most of
it building a figure, paths and artists for a picture a few kilobytes big; Pillow fills the same polygons in
C, at twice the size, then halves the picture (the anti-aliasing matplotlib gave the bones and dots).

Needs Pillow (``pip install 'autorig[preview]'``; matplotlib depends on it too).
"""
from __future__ import annotations

from io import BytesIO

import numpy as np

from ..input.mesh import frame_rotation
from .preview import choose_views, joint_colours, simplified
from ..result import Rig

__all__ = ["render_thumbnails"]

# A thumbnail 160 pixels high shows no more than this: denser meshes are simplified before drawing (drawing
# 120k faces took 6 s a thumbnail, 4,000 take about 0.1 s, and the decimation 0.3 s).
THUMBNAIL_FACES = 4000
_SUPERSAMPLE = 2        # drawn at twice the size, then halved: smooth bones and dots
_PAD = 0.04             # margin around the drawing, a share of its larger side
# Sizes in output pixels, as matplotlib drew them at 100 dpi (a point is 100/72 pixels).
_BONE_WIDTH = 1.25
_HALO_WIDTH = 2.8
_JOINT_DIAMETER = 3.75
_TIP_DIAMETER = 2.3


def render_thumbnails(rig: Rig, height: int = 160, up: str | None = None, front: str | None = None,
                      quality: int = 70) -> dict[str, bytes]:
    """Small pictures of ``rig`` for a page of many rigs (``autorig batch --html``): {view: WebP bytes} for the
    two views ``autorig.show.preview.render_preview`` draws ("front" and "side"; "top" and one of those for a flat
    shape), each ``height`` pixels high and as wide as the view needs (at most twice as wide).

    up, front  as for ``render_preview``
    quality    WebP quality (0-100): 70 keeps the bones and joints sharp at a few kilobytes a view
    Raises ``ImportError`` without Pillow.
    """
    from PIL import Image

    frame = frame_rotation(up or rig.info.get("up", "y"), front or rig.info.get("front", "z"))
    vertices = np.asarray(rig.vertices, dtype=np.float64) @ frame.T
    joints = np.asarray(rig.joints, dtype=np.float64) @ frame.T
    faces = np.asarray(rig.faces, dtype=np.int64)
    face_joint = np.argmax(np.asarray(rig.weights)[faces].sum(axis=1), axis=1)             # [F] strongest joint
    if len(faces) > THUMBNAIL_FACES:
        vertices, faces, face_joint = simplified(vertices, faces, face_joint, THUMBNAIL_FACES, height)
    tips = np.array([name.endswith("_end") for name in rig.names], dtype=bool)
    face_colours = joint_colours(len(rig.names))[face_joint]
    pictures = {}
    for name, _, screen_x, screen_y, toward_camera in choose_views(vertices):
        span = max(float(np.ptp(vertices @ screen_y)), 1e-12)
        aspect = min(max(1.08 * float(np.ptp(vertices @ screen_x)) / span, 0.3), 2.0)
        size = (max(int(round(height * aspect)), 1), height)
        image = _draw(vertices, faces, face_colours, joints, rig.bones, tips, screen_x, screen_y, toward_camera,
                      size)
        buffer = BytesIO()
        image.save(buffer, format="webp", quality=quality, method=4)
        pictures[name] = buffer.getvalue()
    return pictures


def _draw(vertices, faces, face_colours, joints, bones, tips, screen_x, screen_y, toward_camera, size):
    """One orthographic view as a PIL image of ``size`` (width, height) pixels.

    vertices [V, 3], joints [J, 3]  in the character's frame; faces [F, 3] with face_colours [F, 3] (0-1)
    bones [(parent, child)]; tips [J] bool: joints drawn small and grey
    screen_x, screen_y, toward_camera [3]: the frame directions drawn rightwards, upwards and at the viewer
    """
    from PIL import Image, ImageDraw

    k = _SUPERSAMPLE
    width, height = size[0] * k, size[1] * k
    mesh_xy = np.stack([vertices @ screen_x, vertices @ screen_y], axis=1)       # [V, 2]
    joint_xy = np.stack([joints @ screen_x, joints @ screen_y], axis=1)          # [J, 2]
    # The box of the surface and the skeleton, padded, fitted into the picture with equal scales and centred.
    used = mesh_xy[np.unique(faces)] if len(faces) else mesh_xy
    points = np.concatenate([used, joint_xy])
    low, high = points.min(axis=0), points.max(axis=0)
    pad = _PAD * float(max(high - low))
    low, high = low - pad, high + pad
    scale = min(width / max(high[0] - low[0], 1e-12), height / max(high[1] - low[1], 1e-12))
    offset = np.array([width, height]) / 2 - scale * (low + high) / 2

    def to_pixels(xy):                                                         # y grows downwards in images
        pixels = xy * scale + offset
        return np.stack([pixels[:, 0], height - pixels[:, 1]], axis=1)

    corners = vertices[faces]                                                   # [F, 3, 3]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1)
    facing = np.abs(normals @ toward_camera) / np.where(length > 0, length, 1.0)
    # Faces are lit from the camera whichever way they are wound: inward-facing parts still read as solid.
    shade = 0.35 + 0.65 * facing
    order = np.argsort(corners.mean(axis=1) @ toward_camera, kind="stable")    # far to near
    fills = np.round(255 * face_colours[order] * shade[order, None]).astype(np.uint8)
    triangles = to_pixels(mesh_xy[faces[order]].reshape(-1, 2)).reshape(-1, 6)

    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    for triangle, fill in zip(triangles.tolist(), map(tuple, fills.tolist())):
        draw.polygon(triangle, fill=fill)
    ends = to_pixels(joint_xy)
    for colour, line_width in (("white", _HALO_WIDTH), ("black", _BONE_WIDTH)):
        for parent, child in bones:
            draw.line([tuple(ends[parent]), tuple(ends[child])], fill=colour, width=max(round(line_width * k), 1))
    for is_tip, diameter, fill in ((False, _JOINT_DIAMETER, (255, 0, 0)), (True, _TIP_DIAMETER, (153, 153, 153))):
        radius = diameter * k / 2
        for x, y in ends[tips == is_tip]:
            draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=fill, outline="black", width=1)
    return image.reduce(k)
