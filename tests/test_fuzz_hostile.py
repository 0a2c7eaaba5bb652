"""Hostile files, generated (issue 42): the fuzzing suite's second half. ``tests/test_fuzz.py`` mutates the bytes of
real inputs; here hypothesis builds each family of hostile input an attacker would write, from its parts:

- glTF JSON of the wrong shapes (a value of the wrong kind anywhere in the document, deep nesting, a top level
  that is no object), accessors, buffer views and attributes that lie (component types, types, counts, strides,
  offsets, set numbers, views missing, compression extensions), nodes (long chains, cycles, non-finite and huge
  transforms), images and buffers named by hostile URIs (outside the folder, control characters, FIFOs);
- OBJ and OFF text with faces of up to 100,000 corners, indices too large for any integer, non-finite
  coordinates, lying OFF counts, material libraries named thousands of times or hostile names, names with
  control characters, in files whose own names hold control characters or bytes that are not UTF-8;
- random triangle soups, rigged with a template (the distance field, spheres and search's budgets);
- ``--skeleton`` files of random joints, hierarchies and numbers.

Each case is rigged through the command line in this process, as ``test_fuzz.run_case`` does, and must end in
a rig or in one error line with a documented exit code (never 70), with no traceback, no raw control character
on the terminal, within ``CASE_SECONDS`` and 3 GB more address space, and no partial output. Bounded and
deterministic (``derandomize``): 405 cases, ~25 s on two shared cores; ``AUTORIG_FUZZ_EXAMPLES``
scales them, ``AUTORIG_FUZZ_STATS=FILE`` writes the count and the longest case of the whole fuzzing suite.
"""
from __future__ import annotations

import json
import os
import re
import tempfile
import time
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from hostile_files import PNG, _box, _gltf
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fuzz import ALLOWED_EXITS, CASE_SECONDS, STATS, _bounded, _report_stats  # noqa: F401 (the fixture)

from autorig.cli import cli

# Cases per family (test_fuzz's per-kind count, 80 by default, divided by each family's cost).
EXAMPLES = int(os.environ.get("AUTORIG_FUZZ_EXAMPLES", 80))
SETTINGS = settings(deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f]")
FIFO = None        # a file whose bytes are None is made a FIFO


def run_files(family: str, files: dict[str, bytes | None], mesh: str, options: list[str]) -> None:
    """Rig ``mesh`` among ``files`` (name -> bytes, or ``FIFO``) in a fresh folder; check how it ended."""
    with tempfile.TemporaryDirectory(prefix="autorig-fuzz-") as scratch:
        folder = Path(scratch, "in")
        folder.mkdir()
        for name, data in files.items():
            path = folder / name
            if data is FIFO:
                os.mkfifo(path)
            else:
                path.write_bytes(data)
        out = Path(scratch, "out")
        out.mkdir()
        arguments = [str(folder / mesh), "-o", str(out / "rig.glb"), "-q"]
        arguments += [str(folder / o) if o in files else o for o in options]
        start = time.perf_counter()
        result = _bounded(lambda: CliRunner().invoke(cli, arguments, prog_name="autorig"))
        seconds = time.perf_counter() - start
        STATS.append((family, seconds, result.exit_code))
        left = sorted(p.name for p in out.iterdir())
    described = f"{family}: exit {result.exit_code}, stderr {result.stderr[:2000]!r}"
    assert result.exit_code in ALLOWED_EXITS, described
    assert "Traceback" not in result.output and "Traceback" not in result.stderr, described
    assert not CONTROL.search(result.stderr), described
    assert seconds < CASE_SECONDS, described
    errors = [line for line in result.stderr.splitlines() if not line.startswith("autorig: warning: ")]
    if result.exit_code == 0:
        assert errors == [] and left == ["rig.glb"], described
    else:
        assert len(errors) == 1 and errors[0].startswith("autorig: error: "), described
        assert left == [], f"{described}; left behind: {left}"


SKELETON = json.dumps({"joints": [{"name": "hips", "parent": None, "position": [0, 0, 0]},
                                  {"name": "spine", "parent": "hips", "position": [0, 0.5, 0]},
                                  {"name": "head", "parent": "spine", "position": [0, 0.8, 0]}]}).encode()
SKIN = ["--skeleton", "skeleton.json"]      # a quick rig (no embedding): the input's handling is what is tested

# Values of every JSON kind, the hostile ones among them.
BIG = [0, -1, 1, 2, 3, 4, 12, 255, 65535, 2**31 - 1, 2**31, 2**32, 2**53 + 1, 2**63, 2**64, 10**20, 10**300,
       10**400]   # the last too large for a float
NAMES = st.text(st.characters(max_codepoint=0x2FF, blacklist_categories=("Cs",)), max_size=12) | st.sampled_from(
    ["\x1b[2J\x1b[H", "a\0b", "\udce9".encode("utf-8", "surrogatepass").decode("utf-8", "replace"), "..", "/",
     "../../../../etc/passwd", "/etc/passwd", "/dev/zero", "file:///etc/passwd", "http://example.com/x",
     "data:application/octet-stream;base64,@@@", "%2e%2e/x", "x" * 5000, "C:\\x", "fifo"])
SCALARS = (st.sampled_from(BIG) | st.integers(-2**64, 2**64) | st.floats(allow_nan=False, allow_infinity=False)
           | st.sampled_from([1e308, -1e308, 5e-324]) | st.booleans() | st.none() | NAMES)
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(NAMES, inner, max_size=4), max_leaves=8)
NEST = "@@nest@@"        # placeholder in a dumped document for a nesting written as text


def _box_files() -> tuple[dict, bytes]:
    V, F = _box()
    return _gltf(V, F), ("\n".join([f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in V]
                                   + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]) + "\n").encode()


def _dumped(document) -> bytes:
    text = json.dumps(document)
    return re.sub(f'"{NEST}(\\d+)"', lambda m: "[" * int(m[1]) + "]" * int(m[1]), text).encode()


@st.composite
def gltf_json(draw):
    """The box's glTF with a value of any kind put anywhere in it (or a deep nesting), or no object at all."""
    document, _ = _box_files()
    if draw(st.integers(0, 9)) == 0:
        top = draw(st.sampled_from(["[]", "5", '"x"', "null", "[" * 5000 + "]" * 5000, "{", ""]))
        return top.encode()
    for _ in range(draw(st.integers(1, 3))):
        node = document
        while True:     # walk down a random path, stopping anywhere: node[key] is replaced
            key = draw(st.sampled_from(list(node) if isinstance(node, dict) else range(len(node))))
            child = node[key]
            if not isinstance(child, (dict, list)) or not child or draw(st.integers(0, 2)) == 0:
                break
            node = child
        node[key] = draw(VALUES | st.integers(10, 20_000).map(lambda d: f"{NEST}{d}"))
    return _dumped(document)


COMPONENTS = [5120, 5121, 5122, 5123, 5124, 5125, 5126, 5130, 0, -1, 2**40]
TYPES = ["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "bogus", 3]
ATTRIBUTES = ["TEXCOORD_{}", "COLOR_{}", "JOINTS_{}", "WEIGHTS_{}", "NORMAL", "TANGENT", "_CUSTOM_{}"]


@st.composite
def gltf_accessors(draw):
    """The box's glTF with its accessors, views, buffers and attributes lying (1 to 4 changes)."""
    d, _ = _box_files()
    count = d["accessors"][0]["count"]
    primitive = d["meshes"][0]["primitives"][0]
    for _ in range(draw(st.integers(1, 4))):
        a = d["accessors"][draw(st.integers(0, 1))]
        view = d["bufferViews"][draw(st.integers(0, 1))]
        change = draw(st.integers(0, 11))
        if change == 0:
            a["componentType"] = draw(st.sampled_from(COMPONENTS))
        elif change == 1:
            a["type"] = draw(st.sampled_from(TYPES))
        elif change == 2:
            a["count"] = draw(st.sampled_from(BIG + [count - 1, count + 1]))
        elif change == 3:
            a["normalized"] = draw(st.booleans())
            a["componentType"] = draw(st.sampled_from([5120, 5121, 5122, 5123]))
        elif change == 4:
            a["byteOffset"] = draw(st.sampled_from(BIG))
        elif change == 5:
            view["byteStride"] = draw(st.sampled_from([0, 1, 3, 4, 5, 11, 12, 13, 252, 256, 2**31]))
        elif change in (6, 7):
            view[draw(st.sampled_from(["byteOffset", "byteLength", "buffer"]))] = draw(st.sampled_from(BIG))
        elif change == 8:
            a.pop("bufferView", None)
            a["count"] = draw(st.sampled_from(BIG))
        elif change == 9:
            name = draw(st.sampled_from(ATTRIBUTES)).format(draw(st.sampled_from(BIG[:8] + [1000, 10**6, 10**7])))
            d["accessors"].append({"bufferView": 0, "componentType": draw(st.sampled_from(COMPONENTS)),
                                   "count": draw(st.sampled_from([count, count // 2, 2**31])),
                                   "type": draw(st.sampled_from(TYPES))})
            primitive["attributes"][name] = len(d["accessors"]) - 1
        elif change == 10:
            extension = draw(st.sampled_from(["KHR_draco_mesh_compression", "EXT_meshopt_compression",
                                              "KHR_mesh_quantization", "EXT_bogus"]))
            d["extensionsUsed"] = d["extensionsRequired"] = [extension]
            primitive["extensions"] = {extension: {"bufferView": 0, "attributes": {"POSITION": 0}}}
            a["count"] = draw(st.sampled_from(BIG))
        else:
            a["sparse"] = {"count": draw(st.sampled_from(BIG)),
                           "indices": {"bufferView": 1, "componentType": 5125},
                           "values": {"bufferView": 0}}
    primitive["mode"] = draw(st.sampled_from([4, 4, 4, 0, 1, 5, 6, 7, -1]))
    return _dumped(d)


@st.composite
def gltf_nodes(draw):
    """The box's glTF under a hostile node tree: long chains, cycles, huge or non-finite transforms."""
    d, _ = _box_files()
    length = draw(st.sampled_from([1, 2, 50, 5_000]))
    nodes = [{"children": [i + 1], "name": draw(NAMES)} for i in range(length - 1)] + [{"mesh": 0}]
    number = st.sampled_from([0.0, 1.0, -1.0, 1e-300, 1e30, 1e308, -1e308, float("nan"), float("inf"), 10**400])
    for _ in range(draw(st.integers(1, 3))):
        node = nodes[draw(st.integers(0, length - 1))]
        change = draw(st.integers(0, 5))
        if change == 0:
            node["scale"] = [draw(number) for _ in range(3)]
        elif change == 1:
            node["translation"] = [draw(number) for _ in range(3)]
        elif change == 2:
            node["rotation"] = [draw(number) for _ in range(4)]
        elif change == 3:
            node["matrix"] = [draw(number) for _ in range(16)]
        elif change == 4:
            node.setdefault("children", []).append(draw(st.sampled_from([0, length - 1, length, -1, 2**40])))
        else:
            node["mesh"] = draw(st.sampled_from([0, 1, -1, 2**31]))
    d["nodes"] = nodes
    d["scenes"] = [{"nodes": [draw(st.sampled_from([0, 0, 0, length, -1]))]}]
    d["scene"] = draw(st.sampled_from([0, 0, 0, 1, -1, None]))
    return json.dumps(d).encode()      # Python writes NaN and Infinity, as a careless writer does


@st.composite
def gltf_uris(draw):
    """(files) the box's glTF naming images and buffers by hostile URIs; some name a FIFO or one PNG 300 times."""
    d, _ = _box_files()
    files: dict[str, bytes | None] = {"skin.png": PNG, "fifo": FIFO}
    images = draw(st.lists(NAMES | st.sampled_from(["skin.png", "fifo", 5, None, ["skin.png"]]), min_size=1,
                           max_size=4))
    if draw(st.integers(0, 5)) == 0:
        images = ["skin.png"] * 300
    d["images"] = [{"uri": uri} for uri in images]
    d["textures"] = [{"source": i} for i in range(len(images))]
    d["materials"] = [{"name": draw(NAMES), "pbrMetallicRoughness": {"baseColorTexture": {"index": i}}}
                      for i in range(len(images))]
    d["meshes"][0]["primitives"][0]["material"] = len(images) - 1
    if draw(st.booleans()):
        d["buffers"].append({"byteLength": draw(st.sampled_from(BIG)), "uri": draw(NAMES)})
    files["hostile.gltf"] = json.dumps(d).encode()
    return files


def _obj_name(draw) -> str:
    return draw(st.sampled_from(["hostile.obj", "bad\x1b[2J\x07.obj", os.fsdecode(b"caf\xe9.obj"),
                                 "new\nline.obj", "tab\t.obj"]))


@st.composite
def obj_files(draw):
    """(files, mesh name) the box as OBJ, with hostile faces, indices, numbers, material libraries and names."""
    _, text = _box_files()
    lines = text.decode().splitlines()
    files: dict[str, bytes | None] = {"m.mtl": b"newmtl skin\nKd 0.8 0.6 0.5\nmap_Kd skin.png\n", "skin.png": PNG,
                                      "fifo.mtl": FIFO}
    index = st.sampled_from(["1", "-1", "0", "3", "99999999999999999999999", "-99999999999999999999999",
                             "9" * 40, "1.5", "1e3", "nan", "2147483648", "18446744073709551616", "1/1/1", "//"])
    number = st.sampled_from(["0", "1", "nan", "inf", "-inf", "1e309", "-1e309", "1e-320", "0x10", "--1", ""])
    head: list[str] = []
    for _ in range(draw(st.integers(1, 4))):
        change = draw(st.integers(0, 5))
        if change == 0:
            corners = draw(st.sampled_from([3, 4, 100, 10_000, 100_000]))
            picks = np.random.default_rng(draw(st.integers(0, 9))).integers(1, 99, corners)
            lines.append("f " + " ".join(map(str, picks)))
        elif change == 1:
            lines.append("f " + " ".join(draw(index) for _ in range(draw(st.integers(1, 5)))))
        elif change == 2:
            lines.insert(draw(st.integers(0, len(lines))), "v " + " ".join(draw(number) for _ in range(3)))
        elif change == 3:
            library = draw(st.sampled_from(["m.mtl", "fifo.mtl", "/dev/zero", "../../../../proc/self/environ",
                                            "/etc/passwd", "m.mtl\x1b[2J", "missing.mtl"]))
            head += [f"mtllib {library}"] * draw(st.sampled_from([1, 2, 2_000]))
        elif change == 4:
            head.append(f"{draw(st.sampled_from(['usemtl', 'o', 'g', 's']))} {draw(NAMES)}")
        else:
            lines.insert(draw(st.integers(0, len(lines))),
                         draw(st.sampled_from(["vt", "vn"])) + " " + " ".join(draw(number) for _ in range(3)))
    name = _obj_name(draw)
    files[name] = ("\n".join(head + ["usemtl skin"] + lines) + "\n").encode("utf-8", "surrogateescape")
    return files, name


@st.composite
def off_text(draw):
    """The box as OFF with lying counts, a face of many corners, overflowing indices, non-finite numbers."""
    V, F = _box()
    counts = [len(V), len(F), 0]
    vertices = [f"{x} {y} {z}" for x, y, z in V]
    faces = [f"3 {a} {b} {c}" for a, b, c in F]
    for _ in range(draw(st.integers(1, 3))):
        change = draw(st.integers(0, 3))
        if change == 0:
            counts[draw(st.integers(0, 2))] = draw(st.sampled_from(BIG + [-5]))
        elif change == 1:
            corners = draw(st.sampled_from([4, 1000, 100_000, 2**40]))
            shown = min(corners, 100_000)
            faces.append(f"{corners} " + " ".join(map(str, np.arange(shown) % len(V))))
        elif change == 2:
            faces[draw(st.integers(0, len(faces) - 1))] = "3 0 1 " + draw(st.sampled_from(
                ["99999999999999999999999", "-1", "2147483648", "nan", "1e3"]))
        else:
            vertices[draw(st.integers(0, len(vertices) - 1))] = " ".join(
                draw(st.sampled_from(["nan", "inf", "1e309", "0"])) for _ in range(3))
    return ("OFF\n" + " ".join(map(str, counts)) + "\n" + "\n".join(vertices + faces) + "\n").encode()


@st.composite
def soup(draw):
    """A random triangle soup: 4-300 points in a box, 1-600 triangles among them."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    points = draw(st.integers(4, 300))
    V = rng.random((points, 3)) * rng.uniform(0.1, 2.0, 3)
    F = rng.integers(0, points, (draw(st.integers(1, 600)), 3))
    return ("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in V.tolist())
            + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F.tolist())).encode()


@st.composite
def skeleton_json(draw):
    """A ``--skeleton`` file of random joints: counts, hierarchies (unknown, cyclic, repeated), numbers, nesting."""
    if draw(st.integers(0, 9)) == 0:
        depth = draw(st.sampled_from([10, 5_000, 100_000]))
        return ('{"joints": ' + "[" * depth + "]" * depth + "}").encode()
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    count = draw(st.sampled_from([1, 2, 5, 40, 120, 1_001]))
    joints = [{"name": f"j{i}", "parent": f"j{int(rng.integers(0, i))}" if i else None,
               "position": (rng.random(3) * 0.5 - [0.25, 0, 0.15]).tolist()} for i in range(count)]
    for _ in range(draw(st.integers(0, 3))):
        joint = joints[draw(st.integers(0, count - 1))]
        change = draw(st.integers(0, 3))
        if change == 0:
            joint["position"] = [draw(st.sampled_from([0.0, 1e308, -1e308, float("nan"), float("inf"), 10**400]))
                                 for _ in range(3)]
        elif change == 1:
            joint["parent"] = draw(st.sampled_from([joint["name"], "nobody", None, 5, "j0"]))
        elif change == 2:
            joint["name"] = draw(NAMES)
        else:
            joint["position"] = draw(VALUES)
    return json.dumps({"joints": joints}).encode()


def _family(name: str, strategy, examples: int, files_of):
    @settings(SETTINGS, max_examples=max(1, examples))
    @given(case=strategy)
    def test(case):
        files, mesh, options = files_of(case)
        run_files(f"hostile_{name}", files, mesh, options)
    test.__name__ = f"test_hostile_{name}"
    return test


def _gltf_case(data: bytes):
    return {"hostile.gltf": data, "skeleton.json": SKELETON}, "hostile.gltf", SKIN


def _with_skeleton(files: dict, mesh: str):
    return {**files, "skeleton.json": SKELETON}, mesh, SKIN


FAMILIES = {
    "gltf_json": (gltf_json(), EXAMPLES, _gltf_case),
    "gltf_accessors": (gltf_accessors(), EXAMPLES, _gltf_case),
    "gltf_nodes": (gltf_nodes(), EXAMPLES // 2, _gltf_case),
    "gltf_uris": (gltf_uris(), EXAMPLES // 2, lambda files: _with_skeleton(files, "hostile.gltf")),
    "obj": (obj_files(), EXAMPLES, lambda case: _with_skeleton(*case)),
    "off": (off_text(), EXAMPLES // 2, lambda data: _with_skeleton({"hostile.off": data}, "hostile.off")),
    # A soup is a whole rig (the template's embedding included, ~1-4 s when it gets that far).
    "soup": (soup(), EXAMPLES // 16, lambda data: ({"soup.obj": data}, "soup.obj", [])),
    "skeleton": (skeleton_json(), EXAMPLES // 2,
                 lambda data: ({"box.obj": _box_files()[1], "skeleton.json": data}, "box.obj", SKIN)),
}

for _name, (_strategy, _examples, _files_of) in FAMILIES.items():
    globals()[f"test_hostile_{_name}"] = _family(_name, _strategy, _examples, _files_of)
