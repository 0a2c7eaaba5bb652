"""A rig as one JSON file: skeleton, sparse skin weights, diagnostics and timings (no mesh).

Layout (keys in this order; one joint and one weight row per line)::

    {
     "format": "autorig-rig",
     "version": 1,
     "template": "biped",
     "joints": [
      {"name": "hips", "parent": -1, "position": [0.0, 0.93, 0.01]},
      ...
     ],
     "weights": {
      "joint_names": ["hips", ...],
      "vertex_count": 5023,
      "rows": [
       [[0, 3], [0.75, 0.25]],
       ...
      ]
     },
     "info": {...},
     "timings": {"embed": 1.25, ...}
    }

``joints`` lists the joints in rig order, parents before children; ``parent`` is an index into that list,
-1 for the root. ``position`` is in the input mesh's coordinates, rounded to 9 significant digits.

``weights.rows`` has one entry per vertex, in input order: ``[[joint indices], [weights]]``, the vertex's
nonzero weights and the joints they belong to, in increasing joint order. Weights are rounded to 6 decimals
and those that round to 0 are left out, so each row sums to 1 within about 1e-5. Joint ``j`` is
``joint_names[j]`` (the same order as ``joints``).

``info`` and ``timings`` are ``rig.info`` and ``rig.timings`` with keys sorted; numpy values become plain
JSON, NaN and infinities become ``null``, and anything else JSON cannot hold becomes its ``str``.

The same rig always gives the same bytes.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..result import Rig
from .arrays import check_rig, decimal_strings
from .files import write_file_atomic

__all__ = ["write_json", "json_bytes", "read_json", "FORMAT_NAME", "FORMAT_VERSION"]

FORMAT_NAME = "autorig-rig"
FORMAT_VERSION = 1


def write_json(rig: Rig, path: str | os.PathLike) -> None:
    """Write ``rig`` as JSON (see the module docstring), atomically; ``OutputError`` if it cannot be."""
    write_file_atomic(path, json_bytes(rig))


def json_bytes(rig: Rig) -> bytes:
    """The JSON file for ``rig``, UTF-8."""
    check_rig(rig)
    parents = np.asarray(rig.parents, dtype=np.int64)
    joints = [{"name": str(name), "parent": int(parent), "position": [float(f"{x:.9g}") for x in position]}
              for name, parent, position in zip(rig.names, parents, np.asarray(rig.joints, dtype=np.float64))]
    weights = np.asarray(rig.weights, dtype=np.float64)
    # np.nonzero scans row by row, so each row's entries come out together and in joint order.
    rows, columns = np.nonzero(np.round(weights * 1e6))
    index_texts = np.array([str(j) for j in range(len(rig.names))], dtype=object)[columns]
    weight_texts = decimal_strings(weights[rows, columns], 6)
    row_starts = np.searchsorted(rows, np.arange(1, len(weights)))
    table = [f"[[{', '.join(j)}], [{', '.join(w)}]]"
             for j, w in zip(np.split(index_texts, row_starts), np.split(weight_texts, row_starts))]

    lines = [
        "{",
        f' "format": {_dumps(FORMAT_NAME)},',
        f' "version": {FORMAT_VERSION},',
        f' "template": {_dumps(str(rig.template))},',
        f' "joints": {_block([_dumps(j) for j in joints], 1)},',
        ' "weights": {',
        f'  "joint_names": {_dumps([str(n) for n in rig.names])},',
        f'  "vertex_count": {len(weights)},',
        f'  "rows": {_block(table, 2)}',
        " },",
        f' "info": {_indented(_plain(rig.info), 1)},',
        f' "timings": {_indented(_plain(rig.timings), 1)}',
        "}",
    ]
    return ("\n".join(lines) + "\n").encode("utf-8")


def read_json(path: str | os.PathLike) -> Rig:
    """Read a file written by :func:`write_json` back as a :class:`Rig` (raises ``InputError``).

    The file holds no mesh: ``vertices`` and ``faces`` come back empty ([0, 3]) while ``weights`` is dense
    [vertex_count, J]; pair the result with the mesh it was made from before writing it in another format.
    """
    path = Path(path)
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None
    except ValueError as e:  # includes UnicodeDecodeError
        raise InputError(f"cannot read {path}: not JSON ({e})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT_NAME:
        raise InputError(f"cannot read {path}: not an autorig rig file")
    if document.get("version") != FORMAT_VERSION:
        raise InputError(f"cannot read {path}: unsupported version {document.get('version')!r}")
    try:
        joints = document["joints"]
        names = [str(j["name"]) for j in joints]
        parents = np.array([int(j["parent"]) for j in joints], dtype=np.int64)
        positions = np.array([j["position"] for j in joints], dtype=np.float64).reshape(len(joints), 3)
        table = document["weights"]
        weights = np.zeros((int(table["vertex_count"]), len(joints)))
        for i, (columns, values) in enumerate(table["rows"]):
            weights[i, np.asarray(columns, dtype=np.int64)] = values
        info, timings = dict(document.get("info") or {}), dict(document.get("timings") or {})
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise InputError(f"cannot read {path}: malformed rig file ({type(e).__name__}: {e})") from None
    return Rig(names=names, parents=parents, joints=positions, weights=weights,
               vertices=np.zeros((0, 3)), faces=np.zeros((0, 3), dtype=np.int64),
               template=str(document.get("template", "")), timings=timings, info=info)


def _dumps(value) -> str:
    return json.dumps(value, ensure_ascii=False, allow_nan=False, sort_keys=True, separators=(", ", ": "))


def _block(items: list[str], depth: int) -> str:
    """A JSON array of already-rendered ``items``, one per line, indented for nesting level ``depth``."""
    if not items:
        return "[]"
    inner = ",\n".join(" " * (depth + 1) + item for item in items)
    return f"[\n{inner}\n{' ' * depth}]"


def _indented(value, depth: int) -> str:
    return json.dumps(value, ensure_ascii=False, allow_nan=False, sort_keys=True, indent=1).replace(
        "\n", "\n" + " " * depth)


def _plain(value):
    """``value`` as plain JSON data: see the module docstring for what is converted and how."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return _plain(value.item())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)
