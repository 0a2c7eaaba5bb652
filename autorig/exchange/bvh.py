"""Biovision BVH motion files: :func:`read_bvh` parses one into a :class:`Motion`.

A BVH file is a joint hierarchy (each joint an ``OFFSET`` from its parent and a list of ``CHANNELS``, leaves
closed by an ``End Site``) followed by ``MOTION``: a frame count, a frame time and one line of channel values
per frame, in the order the channels were declared. Rotations are in degrees; a joint's rotation channels are
composed in the order they are listed (``Zrotation Yrotation Xrotation`` means Rz @ Ry @ Rx, each about the
joint's own, already rotated, axes). A joint's local transform is translate(offset) then rotate; position
channels replace the offset's matching components (the root's position channels are its absolute position,
which is how CMU, mixamo and Blender's exporter all write them).
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..input.limits import read_regular

__all__ = ["Motion", "read_bvh", "parse_bvh"]

_CHANNELS = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")


@dataclass
class Motion:
    """A BVH skeleton and its motion, in the file's own units and axes.

    names       [B] joint names, in file order (parents before children)
    parents     [B] int, index of each joint's parent, -1 for the root
    offsets     [B, 3] float64 each joint's rest offset from its parent (the root's: its rest position)
    channels    [B] list of each joint's channel names, in file order (e.g. ``["Zrotation", "Xrotation"]``)
    end_sites   {joint index: [3] offset of its End Site}
    frame_time  seconds per frame
    frames      [N, C] float64 channel values, C = total channel count, columns in declaration order
    """
    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[list[str]]
    end_sites: dict[int, np.ndarray]
    frame_time: float
    frames: np.ndarray

    @property
    def times(self) -> np.ndarray:
        """[N] seconds of each frame, from 0."""
        return np.arange(len(self.frames)) * self.frame_time

    def rest_positions(self) -> np.ndarray:
        """[B, 3] joint positions in the rest pose (all channels zero, root at its offset)."""
        positions = np.zeros((len(self.names), 3))
        for b, p in enumerate(self.parents):
            positions[b] = self.offsets[b] + (positions[p] if p >= 0 else 0.0)
        return positions

    def local_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Every frame's local rotations [N, B, 3, 3] and translations [N, B, 3] (offset or position channels)."""
        N, B = len(self.frames), len(self.names)
        rotations = np.tile(np.eye(3), (N, B, 1, 1))
        translations = np.tile(self.offsets, (N, 1, 1))
        column = 0
        for b, channels in enumerate(self.channels):
            for name in channels:
                values = self.frames[:, column]
                column += 1
                axis = "XYZ".index(name[0])
                if name.endswith("position"):
                    translations[:, b, axis] = values
                else:
                    rotations[:, b] = rotations[:, b] @ _axis_rotations(axis, np.radians(values))
        return rotations, translations

    def world_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Every frame's world rotations [N, B, 3, 3] and joint positions [N, B, 3] (forward kinematics)."""
        local_r, local_t = self.local_transforms()
        world_r, world_t = np.empty_like(local_r), np.empty_like(local_t)
        for b, p in enumerate(self.parents):
            if p < 0:
                world_r[:, b], world_t[:, b] = local_r[:, b], local_t[:, b]
            else:
                world_r[:, b] = world_r[:, p] @ local_r[:, b]
                world_t[:, b] = world_t[:, p] + np.einsum("nij,nj->ni", world_r[:, p], local_t[:, b])
        return world_r, world_t

    def children(self, b: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == b)]


def _axis_rotations(axis: int, angles: np.ndarray) -> np.ndarray:
    """Rotations [N, 3, 3] by ``angles`` [N] radians about coordinate axis 0, 1 or 2 (right-handed)."""
    c, s = np.cos(angles), np.sin(angles)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros((len(angles), 3, 3))
    out[:, axis, axis] = 1.0
    out[:, i, i], out[:, i, j], out[:, j, i], out[:, j, j] = c, -s, s, c
    return out


def read_bvh(path: str | os.PathLike) -> Motion:
    """Read a ``.bvh`` file; ``InputError`` naming the line if it cannot be read or parsed."""
    path = Path(path)
    try:
        text = read_regular(path, None).decode("utf-8", errors="replace")
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None
    return parse_bvh(text, name=str(path))


def parse_bvh(text: str, name: str = "BVH") -> Motion:
    """Parse BVH ``text``; ``name`` is how error messages refer to it."""
    lines = text.splitlines()
    motion_line = next((i for i, line in enumerate(lines) if line.strip() == "MOTION"), None)
    if motion_line is None:
        raise InputError(f"{name}: no MOTION section")
    tokens = [(word, i + 1) for i, line in enumerate(lines[:motion_line])
              for word in re.findall(r"[^\s:]+:?|:", line)]
    reader = _Tokens(tokens, name)
    reader.expect("HIERARCHY")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    end_sites: dict[int, np.ndarray] = {}

    def joint(parent: int) -> None:
        # After ROOT/JOINT: name { OFFSET x y z CHANNELS n ... (JOINT ... | End Site {...})* }
        index = len(names)
        names.append(reader.joint_name())
        parents.append(parent)
        reader.expect("{")
        reader.expect("OFFSET")
        offsets.append([reader.number() for _ in range(3)])
        reader.expect("CHANNELS")
        count = reader.number()
        if not (0 <= count <= len(_CHANNELS) and count == int(count)):
            raise reader.error(f"a joint has 0 to {len(_CHANNELS)} channels, not {count:g}")
        count = int(count)
        listed = [reader.next() for _ in range(count)]
        for channel in listed:
            if channel not in _CHANNELS:
                raise reader.error(f"unknown channel {channel!r}")
        channels.append(listed)
        while True:
            word = reader.next()
            if word == "}":
                return
            if word == "JOINT":
                joint(index)
            elif word == "End":
                reader.expect("Site")
                reader.expect("{")
                reader.expect("OFFSET")
                end_sites[index] = np.array([reader.number() for _ in range(3)])
                reader.expect("}")
            else:
                raise reader.error(f"expected JOINT, End Site or }} but found {word!r}")

    reader.expect("ROOT")
    try:
        joint(-1)
    except RecursionError:  # a hierarchy thousands of joints deep: no skeleton, and Python's stack would end
        raise InputError(f"{name}: the hierarchy nests too deeply") from None
    if reader.at < len(tokens):
        raise reader.error(f"unexpected {tokens[reader.at][0]!r} after the hierarchy")
    return Motion(names=names, parents=np.asarray(parents, dtype=np.int64),
                  offsets=np.asarray(offsets, dtype=np.float64), channels=channels, end_sites=end_sites,
                  **_motion(lines, motion_line, sum(len(c) for c in channels), name))


def _motion(lines: list[str], motion_line: int, width: int, name: str) -> dict:
    """frame_time and frames [N, width] from the lines after ``MOTION`` (at index ``motion_line``)."""
    header = {}
    at = motion_line + 1
    for key in ("Frames", "Frame Time"):
        while at < len(lines) and not lines[at].strip():
            at += 1
        match = re.fullmatch(rf"\s*{key}:\s*(\S+)\s*", lines[at]) if at < len(lines) else None
        if match is None:
            raise InputError(f"{name}: line {at + 1}: expected '{key}: <number>'")
        try:
            header[key] = float(match.group(1))
        except ValueError:
            raise InputError(f"{name}: line {at + 1}: {match.group(1)!r} is not a number") from None
        at += 1
    count, frame_time = header["Frames"], header["Frame Time"]
    if not math.isfinite(count) or count < 0 or count != int(count) or not frame_time > 0:
        raise InputError(f"{name}: bad frame count {count:g} or frame time {frame_time:g}")
    count = int(count)
    try:
        values = np.array(" ".join(lines[at:]).split(), dtype=np.float64)
    except ValueError:
        bad = next(i for i in range(at, len(lines)) if not all(_is_number(w) for w in lines[i].split()))
        raise InputError(f"{name}: line {bad + 1}: a frame holds something that is not a number") from None
    if len(values) < count * width:
        raise InputError(f"{name}: {count} frames of {width} channels need {count * width} values, "
                         f"the file has {len(values)}")
    return {"frame_time": frame_time, "frames": values[: count * width].reshape(count, width)}


class _Tokens:
    """A cursor over (token, line number) pairs that raises ``InputError`` with the line on any surprise."""

    def __init__(self, tokens: list[tuple[str, int]], name: str):
        self.tokens, self.name, self.at = tokens, name, 0

    def error(self, problem: str) -> InputError:
        line = self.tokens[min(self.at, len(self.tokens)) - 1][1] if self.tokens else 1
        return InputError(f"{self.name}: line {line}: {problem}")

    def next(self) -> str:
        if self.at >= len(self.tokens):
            raise self.error("unexpected end of file")
        self.at += 1
        return self.tokens[self.at - 1][0]

    def expect(self, word: str) -> None:
        found = self.next()
        if found != word:
            raise self.error(f"expected {word!r} but found {found!r}")

    def joint_name(self) -> str:
        # Names may contain ':' (mixamo's "mixamorig:Hips"), which the tokenizer split off.
        name = self.next()
        while self.at < len(self.tokens) and self.tokens[self.at][0] != "{":
            name += ("" if name.endswith(":") else " ") + self.next()
        return name

    def number(self) -> float:
        word = self.next()
        try:
            return float(word)
        except ValueError:
            raise self.error(f"expected a number but found {word!r}") from None


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True
