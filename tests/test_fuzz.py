"""Hostile bytes (issue 28): mutated copies of real small inputs, each rigged through the command line in this
process. Every case must end in a rig or in one error line with a documented exit code: never a traceback
(exit 70 is autorig's own internal error), never a hang past its bound, never a partial output file.

The inputs: a small mannequin (``autorig.samples``, ~600 faces) as OBJ with UVs, an MTL and a PNG texture (the
OBJ and the MTL mutated), binary and ASCII PLY and STL, OFF, glTF and GLB written by autorig's own writer; a
template file; JSON and BVH ``--skeleton`` files. Mutations: flipped, inserted, deleted and duplicated bytes,
truncation, and numbers replaced by extreme ones (in text, a number token; in binary, a 32-bit word), which is
how declared counts and offsets go wrong. Bounded and deterministic (``derandomize``): the same cases in CI
every run (``AUTORIG_FUZZ_EXAMPLES=N`` searches further). ``AUTORIG_FUZZ_STATS=FILE`` writes the number of
cases and the longest one there.
"""
from __future__ import annotations

import atexit
import json
import os
import re
import resource
import shutil
import signal
import tempfile
import time
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rig_samples import mannequin_bvh
from test_look import PNG

from autorig.cli import cli

# Documented exit codes a hostile input may end in: rigged, bad input, bad template or skeleton, no fit.
ALLOWED_EXITS = {0, 2, 3, 5}
CASE_SECONDS = 30            # the bound on one case; a case running past it is a hang
# Per input kind (a third of it for templates): ~930 cases in all, about 25 s on two shared cores.
# AUTORIG_FUZZ_EXAMPLES=N runs more, to search further by hand.
EXAMPLES = int(os.environ.get("AUTORIG_FUZZ_EXAMPLES", 80))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
EXTREMES = ["0", "-1", "1", "2147483648", "4294967295", "18446744073709551616", "99999999999999999999999",
            "nan", "inf", "-inf", "1e309", "-0", "0.5", "3"]
WORDS = [0, 1, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0xFFFF, 3, 12]
STATS: list[tuple[str, float, int]] = []    # (kind, seconds, exit code) of every case run


@lru_cache(maxsize=None)
def seeds() -> dict[str, bytes]:
    """The real inputs, by file name, in a folder of their own."""
    import trimesh

    from autorig.exchange.gltf import glb_bytes, gltf_bytes
    from autorig.pipeline import skin
    from autorig.samples import mannequin

    sample = mannequin(resolution=24)
    vertices, faces = sample.vertices, sample.faces
    folder = Path(tempfile.mkdtemp(prefix="autorig-fuzz-seeds-"))
    atexit.register(shutil.rmtree, folder, True)
    uv = (vertices[:, [0, 1]] - vertices[:, [0, 1]].min(0)) / np.ptp(vertices[:, [0, 1]], axis=0)
    obj = ["mtllib man.mtl", "o man"] + [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in vertices]
    obj += [f"vt {u:.4f} {v:.4f}" for u, v in uv] + ["usemtl skin"]
    obj += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in faces]
    files = {"man.obj": ("\n".join(obj) + "\n").encode(),
             "man.mtl": b"newmtl skin\nKd 0.8 0.6 0.5\nmap_Kd -s 1 1 1 skin.png\nd 1\nNs 200\n",
             "skin.png": PNG,
             "man.off": (f"OFF\n{len(vertices)} {len(faces)} 0\n"
                         + "".join(f"{x:.5f} {y:.5f} {z:.5f}\n" for x, y, z in vertices)
                         + "".join(f"3 {a} {b} {c}\n" for a, b, c in faces)).encode()}
    shape = trimesh.Trimesh(vertices, faces, process=False)
    files["man.ply"] = shape.export(file_type="ply", encoding="binary")
    files["man.stl"] = shape.export(file_type="stl")
    for name, kind in (("ascii.ply", "ply"), ("ascii.stl", "stl_ascii")):
        text = shape.export(file_type=kind, **({"encoding": "ascii"} if kind == "ply" else {}))
        files[name] = text.encode() if isinstance(text, str) else text
    for name, data in files.items():
        (folder / name).write_bytes(data)
    skeleton = {"joints": [{"name": "hips", "parent": None, "position": [0, 0.5, 0]},
                           {"name": "spine", "parent": "hips", "position": [0, 0.65, 0]},
                           {"name": "head", "parent": "spine", "position": [0, 0.9, 0]},
                           {"name": "left_knee", "parent": "hips", "position": [0.08, 0.27, 0]},
                           {"name": "right_knee", "parent": "hips", "position": [-0.08, 0.27, 0]}]}
    files["skeleton.json"] = json.dumps(skeleton, indent=1).encode()
    (folder / "skeleton.json").write_bytes(files["skeleton.json"])
    rig = skin(str(folder / "man.obj"), str(folder / "skeleton.json"))
    files["man.gltf"], files["man.glb"] = gltf_bytes(rig), glb_bytes(rig)
    files["skeleton.bvh"] = mannequin_bvh([{}], [(0.0, 0.0, 0.0)]).encode()
    files["template.json"] = (Path(__file__).resolve().parents[1] / "templates" / "handset" / "biped.json"
                              ).read_bytes()
    return files


@st.composite
def mutated(draw, data: bytes, text: bool) -> bytes:
    """``data`` after one to four mutations."""
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["flip", "insert", "delete", "duplicate", "truncate", "number", "number"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "flip" and data:
            data[at] ^= 1 << draw(st.integers(0, 7))
        elif kind == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        elif kind == "delete":
            del data[at:at + draw(st.integers(1, 64))]
        elif kind == "duplicate":
            size = draw(st.integers(1, 256))
            data[at:at] = data[at:at + size] * draw(st.integers(1, 3))
        elif kind == "truncate":
            del data[at:]
        elif text:
            numbers = [m.span() for m in re.finditer(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?", bytes(data))]
            if numbers:
                start, end = numbers[draw(st.integers(0, len(numbers) - 1))]
                data[start:end] = draw(st.sampled_from(EXTREMES)).encode()
        elif len(data) >= 4:
            at = min(at, len(data) - 4) & ~3
            data[at:at + 4] = draw(st.sampled_from(WORDS)).to_bytes(4, "little")
    return bytes(data)


# input kind -> (the file mutated, the files beside it, the command line after the mesh)
KINDS = {
    "obj": ("man.obj", ["man.mtl", "skin.png"], ["--skeleton", "skeleton.json"]),
    "mtl": ("man.mtl", ["man.obj", "skin.png"], ["--skeleton", "skeleton.json"]),
    "ply": ("man.ply", [], ["--skeleton", "skeleton.json"]),
    "ascii_ply": ("ascii.ply", [], ["--skeleton", "skeleton.json"]),
    "stl": ("man.stl", [], ["--skeleton", "skeleton.json"]),
    "ascii_stl": ("ascii.stl", [], ["--skeleton", "skeleton.json"]),
    "off": ("man.off", [], ["--skeleton", "skeleton.json"]),
    "gltf": ("man.gltf", [], ["--skeleton", "skeleton.json"]),
    "glb": ("man.glb", [], ["--skeleton", "skeleton.json"]),
    "skeleton_json": ("skeleton.json", ["man.off"], []),
    "skeleton_bvh": ("skeleton.bvh", ["man.off"], []),
    "template": ("template.json", ["man.off"], ["--template", "template.json"]),
}
MESH_OF = {"mtl": "man.obj", "skeleton_json": "man.off", "skeleton_bvh": "man.off", "template": "man.off"}
TEXT = {"obj", "mtl", "ascii_ply", "ascii_stl", "off", "gltf", "skeleton_json", "skeleton_bvh", "template"}


def run_case(kind: str, data: bytes) -> None:
    """Rig with ``data`` as ``kind``'s file, in a fresh folder; check how it ended."""
    mutated_name, beside, options = KINDS[kind]
    if kind == "skeleton_json":
        options = ["--skeleton", "skeleton.json"]
    elif kind == "skeleton_bvh":
        options = ["--skeleton", "skeleton.bvh"]
    with tempfile.TemporaryDirectory(prefix="autorig-fuzz-") as scratch:
        folder = Path(scratch, "in")
        folder.mkdir()
        for name in [*beside, "skeleton.json"]:
            (folder / name).write_bytes(seeds()[name])
        (folder / mutated_name).write_bytes(data)
        out_folder = Path(scratch, "out")
        out_folder.mkdir()
        mesh = folder / MESH_OF.get(kind, mutated_name)
        arguments = [str(mesh), "-o", str(out_folder / "rig.glb"), "-q"]
        arguments += [str(folder / o) if o.endswith((".json", ".bvh")) else o for o in options]
        start = time.perf_counter()
        result = _bounded(lambda: CliRunner().invoke(cli, arguments, prog_name="autorig"))
        seconds = time.perf_counter() - start
        STATS.append((kind, seconds, result.exit_code))
        left = sorted(p.name for p in out_folder.iterdir())
    described = f"{kind}: exit {result.exit_code}, stderr {result.stderr!r}"
    assert result.exit_code in ALLOWED_EXITS, described
    assert "Traceback" not in result.output and "Traceback" not in result.stderr, described
    assert seconds < CASE_SECONDS, described
    errors = [line for line in result.stderr.splitlines() if not line.startswith("autorig: warning: ")]
    if result.exit_code == 0:
        assert errors == [] and left == ["rig.glb"], described
    else:
        assert len(errors) == 1 and errors[0].startswith("autorig: error: "), described
        assert left == [], f"{described}; left behind: {left}"


def _bounded(call):
    """``call()`` under a timer (a hang fails as exit 70 from the interrupt) and an address-space limit of
    3 GB more than now (an unguarded huge allocation fails as a MemoryError, not by the OOM killer)."""
    def interrupt(*_):
        raise TimeoutError(f"a case ran past {CASE_SECONDS} s")
    previous = signal.signal(signal.SIGALRM, interrupt)
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    in_use = int(Path("/proc/self/statm").read_text().split()[0]) * resource.getpagesize()
    resource.setrlimit(resource.RLIMIT_AS, (in_use + 3 * 2**30, hard))
    signal.setitimer(signal.ITIMER_REAL, CASE_SECONDS)
    try:
        return call()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@pytest.fixture(scope="module", autouse=True)
def _report_stats():
    yield
    if STATS and os.environ.get("AUTORIG_FUZZ_STATS"):
        kind, longest, code = max(STATS, key=lambda s: s[1])
        exits: dict[int, int] = {}
        kinds: dict[str, int] = {}
        for k, _, c in STATS:
            exits[c] = exits.get(c, 0) + 1
            kinds[k] = kinds.get(k, 0) + 1
        Path(os.environ["AUTORIG_FUZZ_STATS"]).write_text(json.dumps(
            {"cases": len(STATS), "seconds": round(sum(s for _, s, _ in STATS), 2),
             "longest": {"kind": kind, "seconds": round(longest, 3), "exit": code},
             "exits": {str(k): v for k, v in sorted(exits.items())}, "kinds": kinds}, indent=1) + "\n")


def test_the_seeds_rig():
    for kind in KINDS:
        run_case(kind, seeds()[KINDS[kind][0]])
    assert {code for kind, _, code in STATS[-len(KINDS):]} == {0}


def _fuzz(kind: str):
    # A template that still loads is a whole rig (~1 s, the embedding included); the others are a skin (~0.1 s).
    @settings(SETTINGS, max_examples=EXAMPLES // 3 if kind == "template" else EXAMPLES)
    @given(data=st.data())
    def test(data):
        run_case(kind, data.draw(mutated(seeds()[KINDS[kind][0]], kind in TEXT), label="bytes"))
    test.__name__ = f"test_mutated_{kind}"
    return test


for _kind in KINDS:
    globals()[f"test_mutated_{_kind}"] = _fuzz(_kind)
