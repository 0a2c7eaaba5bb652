"""The same character gets the same rig (issue 37): a file that lists the same mesh's vertices or triangle
corners in another order is the same character. Dense meshes are decimated for the discretization, and quadric
decimation collapses edges in an order that follows the arrays: it must see them in an order of their own."""
import numpy as np
import pytest

import autorig
from autorig.input.mesh import canonical_order
from autorig.pipeline import RigOptions
from autorig.samples import mannequin


def reordered(vertices, faces, seed=3):
    order = np.random.default_rng(seed).permutation(len(vertices))
    where = np.empty_like(order)
    where[order] = np.arange(len(order))
    return vertices[order], np.roll(where[faces], 1, axis=1)


def test_canonical_order_forgets_the_files_order():
    sample = mannequin(pose="a", resolution=40)
    v, f = canonical_order(sample.vertices, sample.faces)
    v2, f2 = canonical_order(*reordered(sample.vertices, sample.faces))
    assert np.array_equal(v, v2) and np.array_equal(f, f2)
    # The same surface: every triangle's corners, as points from its lowest one on, winding kept.
    def triangles(vertices, faces):
        out = set()
        for t in faces:
            points = vertices[t]
            first = int(np.lexsort(points.T[::-1])[0])
            out.add(tuple(map(tuple, np.roll(points, -first, axis=0))))
        return out
    before, after = triangles(sample.vertices, sample.faces), triangles(v, f)
    assert before == after


@pytest.mark.parametrize("pose", ["t"])
def test_a_dense_mesh_in_another_order_gets_the_same_rig(pose):
    sample = mannequin(pose=pose)    # 10k-16k faces: decimated for the discretization
    assert len(sample.faces) > 6000
    options = RigOptions(up="y", front="z")
    base = autorig.rig((sample.vertices, sample.faces), "biped", options)
    other = autorig.rig(reordered(sample.vertices, sample.faces), "biped", options)
    height = np.ptp(sample.vertices[:, 1])
    assert np.abs(np.asarray(other.joints) - np.asarray(base.joints)).max() < 1e-9 * height
