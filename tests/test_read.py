"""One reader for an input file's mesh and look (``autorig.input.read``): each input file read and parsed once
per rig, with what the separate readers return."""
from __future__ import annotations

import os
import pathlib
from pathlib import Path

import numpy as np
import pytest

import autorig
import autorig.exchange.gltf as gltf
from autorig.exchange.gltf import write_glb, write_gltf
from autorig.input.look import load_look
from autorig.input.mesh import load_mesh
from autorig.input.read import read_input

MANNEQUIN = Path(__file__).resolve().parents[1] / "data" / "mannequin.obj"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    """The mannequin as a .glb, a .gltf (with its buffer in a file beside it) and an OBJ with texture
    coordinates: inputs that have a look."""
    folder = tmp_path_factory.mktemp("inputs")
    rig = autorig.rig(MANNEQUIN)
    write_glb(rig, folder / "hero.glb")
    write_gltf(rig, folder / "hero.gltf")
    lines = MANNEQUIN.read_text().splitlines()
    uv = [f"vt {0.5 + 0.4 * x:.4f} {y:.4f}" for x, y, _ in load_mesh(MANNEQUIN)[0]]
    faces = [" ".join(["f"] + [f"{i}/{i}" for i in line.split()[1:]]) if line.startswith("f ") else line
             for line in lines]
    (folder / "hero.obj").write_text("\n".join(faces[:1] + uv + faces[1:]) + "\n")
    return {suffix: folder / f"hero{suffix}" for suffix in (".glb", ".gltf", ".obj")}


def _counting(monkeypatch, owner, name: str) -> list:
    """Replace ``owner.name`` with a wrapper that records each call's first argument."""
    calls, original = [], getattr(owner, name)

    def spy(*args, **kwargs):
        calls.append(args[0] if args else None)
        return original(*args, **kwargs)
    monkeypatch.setattr(owner, name, spy)
    return calls


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_gltf_input_is_read_and_parsed_once_per_rig(inputs, monkeypatch, suffix):
    path = inputs[suffix]
    reads = _counting(monkeypatch, gltf, "file_bytes")
    parses = _counting(monkeypatch, gltf, "parse_document")
    rig = autorig.rig(path)
    assert len(reads) == 1 and Path(reads[0]) == path
    assert len(parses) == 1
    assert rig.look is not None and rig.look.normals is not None


def test_an_obj_input_is_read_from_disk_once_per_rig(inputs, monkeypatch):
    path = inputs[".obj"]
    # Files are read through autorig.input.limits.read_regular, which opens them with os.open (a FIFO or a
    # device is refused before it is opened): count the opens of the OBJ.
    opened = []
    real_open = os.open

    def spy(file, *args, **kwargs):
        opened.append(file)
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(os, "open", spy)
    rig = autorig.rig(path)
    assert [p for p in opened if isinstance(p, (str, Path)) and Path(p) == path] == [path]
    assert rig.look is not None and len(rig.look.texcoords) == 1


@pytest.mark.parametrize("suffix", [".glb", ".gltf", ".obj"])
def test_the_one_reader_returns_what_the_two_readers_do(inputs, suffix):
    path = inputs[suffix]
    vertices, faces, look = read_input(path)
    alone_vertices, alone_faces = load_mesh(path)
    alone_look = load_look(path, alone_faces)
    assert np.array_equal(vertices, alone_vertices) and np.array_equal(faces, alone_faces)
    assert look is not None and alone_look is not None
    for name in ("vertex_of", "faces", "normals", "colors", "face_material"):
        assert np.array_equal(getattr(look, name), getattr(alone_look, name)), name
    assert all(np.array_equal(a, b) for a, b in zip(look.texcoords, alone_look.texcoords, strict=True))
    assert look.materials == alone_look.materials and look.dropped == alone_look.dropped


def test_a_mesh_without_a_look_reads_as_before(tmp_path):
    off = tmp_path / "tetra.off"
    off.write_text("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    for path in (MANNEQUIN, off):
        vertices, faces, look = read_input(path)
        assert look is None
        assert all(np.array_equal(a, b) for a, b in zip((vertices, faces), load_mesh(path)))


def test_the_one_reader_refuses_what_load_mesh_refuses(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"glTF not really")
    with pytest.raises(autorig.AutorigError) as alone:
        load_mesh(bad)
    with pytest.raises(autorig.AutorigError) as together:
        read_input(bad)
    assert str(together.value) == str(alone.value) and together.value.exit_code == 2
