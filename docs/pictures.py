"""Draw the guide's pictures again with autorig's own preview: ``python docs/pictures.py`` (about 10 s).

docs/img/posed.png      the README's picture: the mannequin rigged with the biped, then posed by its own bones
docs/img/mannequin.png  the mannequin, --template biped
docs/img/dog.png        the dog, --template quadruped
docs/img/dog-auto.png   the dog, --template auto
docs/img/stages.png     the mannequin through the stages: working mesh, medial spheres, sphere graph, embedding,
                        refined joints, skin weights

Needs the preview extra (``pip install '.[preview]'``). The rigs are deterministic; the PNGs are small (150 dpi
of matplotlib's default figure, then palette-quantized by Pillow).
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "img"

# The pose of the README's picture: degrees about the rig's own x (pitch) and z (roll) axes, per joint.
POSE = {"left_shoulder": (0, 0, -55), "right_shoulder": (-70, 0, 20), "right_elbow": (0, -60, 0),
        "left_hip": (-25, 0, 0), "left_knee": (40, 0, 0), "right_hip": (10, 0, 0), "neck": (10, 0, 0)}


def _rotation(x_deg: float, y_deg: float, z_deg: float) -> np.ndarray:
    x, y, z = np.radians([x_deg, y_deg, z_deg])
    rx = np.array([[1, 0, 0], [0, np.cos(x), -np.sin(x)], [0, np.sin(x), np.cos(x)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rz = np.array([[np.cos(z), -np.sin(z), 0], [np.sin(z), np.cos(z), 0], [0, 0, 1]])
    return rz @ rx @ ry


def posed(rig, pose: dict[str, tuple[float, float, float]]):
    """``rig`` with its mesh and joints moved: each named joint turned by its angles, its children with it
    (forward kinematics, then ``autorig.show.pose.skin``'s linear blend skinning)."""
    from autorig.show.pose import skin
    joints = np.asarray(rig.joints, dtype=np.float64)
    J = len(rig.names)
    world = np.repeat(np.eye(3)[None], J, axis=0)
    positions = joints.copy()
    for j in range(J):          # a rig's joints come parents first
        p = rig.parents[j]
        local = _rotation(*pose.get(rig.names[j], (0, 0, 0)))
        if p >= 0:
            world[j] = world[p] @ local
            positions[j] = positions[p] + world[p] @ (joints[j] - joints[p])
        else:
            world[j] = local
    vertices = skin(rig, world, positions)
    return replace(rig, vertices=vertices, joints=positions)


def _small_png(path: Path) -> None:
    from PIL import Image
    with Image.open(path) as image:
        small = image.convert("RGB").quantize(colors=64)
    small.save(path, optimize=True)


def draw_stages(path: Path) -> None:
    """The mannequin through the pipeline's stages, front view (the character's left on the right), each panel
    what that stage hands the next: ``autorig.pipeline``'s own functions, run one by one."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection, PatchCollection, PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    import autorig
    from autorig.input.mesh import load_mesh, prepare
    from autorig.pipeline import discretize, embed_and_refine
    from autorig.show.preview import joint_colours
    from autorig.template import load_template

    prepared = prepare(*load_mesh(ROOT / "data" / "mannequin.obj"), up="y", front="z")
    field, graph = discretize(prepared)
    template = load_template("biped")
    embedding, joints = embed_and_refine(field, graph, template)
    rig = autorig.rig(ROOT / "data" / "mannequin.obj", template)
    mesh = prepared.work_vertices[prepared.work_faces][:, :, :2]
    centers = graph.centers[:, :2]
    panels = ["working mesh", "medial spheres", "sphere graph", "embedding", "refined joints", "skin weights"]
    figure = Figure(figsize=(13, 2.9), dpi=100)
    FigureCanvasAgg(figure)
    for k, title in enumerate(panels):
        ax = figure.add_subplot(1, len(panels), k + 1)
        ax.set_title(title, fontsize=10)
        ax.set_aspect("equal")
        ax.axis("off")
        if k == len(panels) - 1:    # each triangle in the colour of its vertices' strongest joint
            strongest = np.asarray(rig.weights).argmax(axis=1)
            colours = joint_colours(len(rig.names))[strongest[np.asarray(rig.faces)[:, 0]]]
            ax.add_collection(PolyCollection(np.asarray(rig.vertices)[np.asarray(rig.faces)][:, :, :2],
                                             facecolors=colours, edgecolors="none"))
        else:
            ax.add_collection(PolyCollection(mesh, facecolors="0.88", edgecolors="0.6" if k == 0 else "none",
                                             linewidths=0.1))
        if k == 1:
            ax.add_collection(PatchCollection([Circle(c, r) for c, r in zip(centers, graph.radii)],
                                              facecolors="none", edgecolors="tab:blue", linewidths=0.5))
        if k == 2:
            ax.add_collection(LineCollection(centers[graph.edges], colors="tab:blue", linewidths=0.5))
            ax.plot(*centers.T, ".", color="tab:blue", markersize=2)
        if k == 3:
            ax.add_collection(LineCollection([centers[path] for path in embedding.paths if len(path) > 1],
                                             colors="tab:red", linewidths=1.5))
            ax.plot(*centers[embedding.spheres].T, "o", color="tab:red", markersize=3)
        if k in (4, 5):
            points = joints[:, :2] if k == 4 else np.asarray(rig.joints)[:, :2]
            bones = [(points[p], points[j]) for j, p in enumerate(template.parents) if p >= 0]
            ax.add_collection(LineCollection(bones, colors="black", linewidths=1.2))
            ax.plot(*points.T, "o", color="tab:red", markersize=3)
        ax.autoscale_view()
    figure.tight_layout()
    figure.savefig(path)


def main() -> None:
    import autorig
    from autorig.show.preview import render_preview

    OUT.mkdir(parents=True, exist_ok=True)
    mannequin = autorig.rig(ROOT / "data" / "mannequin.obj", "biped")
    drawings = {
        "posed.png": (posed(mannequin, POSE), "the mannequin, rigged by autorig and posed by its bones"),
        "mannequin.png": (mannequin, None),
        "dog.png": (autorig.rig(ROOT / "data" / "dog.obj", "quadruped"), None),
        "dog-auto.png": (autorig.rig(ROOT / "data" / "dog.obj", "auto"), None),
    }
    draw_stages(OUT / "stages.png")
    _small_png(OUT / "stages.png")
    for name, (rig, title) in drawings.items():
        render_preview(rig, OUT / name, title=title)
        _small_png(OUT / name)
        print(f"{OUT / name}: {(OUT / name).stat().st_size // 1024} kB", file=sys.stderr)


if __name__ == "__main__":
    main()
