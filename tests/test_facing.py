"""Which way the working copy's pieces face (autorig.input.facing), for pieces with pinholes: judged by their volume."""
import numpy as np
import pytest
import trimesh

from autorig.input import facing
from autorig.input.mesh import prepare


def pinholed_sphere(centre, reverse: bool) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere (20k triangles) with one triangle missing (a scan's pinhole), facing outward unless ``reverse``."""
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.2)
    F = sphere.faces[1:]
    return sphere.vertices + centre, (F[:, ::-1] if reverse else F)


@pytest.mark.parametrize("reverse", [False, True])
def test_a_piece_with_a_pinhole_faces_the_way_its_volume_says(monkeypatch, reverse):
    """A pinhole does not make a piece open for the facing: its volume decides, as for a closed piece, and
    no winding-number tree is built over its triangles (a 1M-face scan saves ~1 s)."""
    def winding_tree(*args):
        raise AssertionError("a piece with a pinhole was judged by its winding number")
    monkeypatch.setattr(facing, "_open_piece_facing", winding_tree)
    # Far from the origin, where an open piece's volume from the origin would say nothing.
    V, F = pinholed_sphere([3.0, 0.5, -2.0], reverse)
    body = trimesh.creation.box(extents=[0.4, 1.0, 0.3])
    V = np.vstack([body.vertices + [0, 0.5, 0], V])
    F = np.vstack([body.faces, F + len(body.vertices)])
    prepared = prepare(V, F)
    work = prepared.work_vertices[prepared.work_faces]
    normals = np.cross(work[:, 1] - work[:, 0], work[:, 2] - work[:, 0])
    outward = work.mean(axis=1) - prepared.to_canonical(np.array([[3.0, 0.5, -2.0]]))
    on_sphere = np.linalg.norm(outward, axis=1) < 0.5 * prepared.scale
    assert on_sphere.sum() == len(F) - 12
    assert np.all(np.einsum("ij,ij->i", normals[on_sphere], outward[on_sphere]) > 0)


def test_a_piece_with_a_wide_opening_is_still_judged_by_its_winding_number(monkeypatch):
    """A bowl (a sphere without its top cap) is no pinholed piece: its winding number decides."""
    calls = []
    real = facing._open_piece_facing
    monkeypatch.setattr(facing, "_open_piece_facing", lambda V, F: calls.append(len(F)) or real(V, F))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.2)
    keep = sphere.triangles_center[:, 1] < 0.1
    body = trimesh.creation.box(extents=[0.4, 1.0, 0.3])
    V = np.vstack([body.vertices + [0, 0.5, 0], sphere.vertices + [1.0, 0.5, 0]])
    F = np.vstack([body.faces, sphere.faces[keep] + len(body.vertices)])
    prepare(V, F)
    assert calls == [int(keep.sum())]
