"""Template skeletons: the joints, hierarchy and proportions that the embedding looks for in a mesh.

A template is a JSON file (see ``templates/biped.json``)::

    {"name": "biped",
     "joints": [{"name": "hips", "parent": null, "position": [0, 0.47, 0]}, ...],
     "symmetry": [["left_hip", "right_hip"], ...],   # mirror pairs (x -> -x)
     "feet": ["left_toe_end", "right_toe_end"],      # joints that should touch the ground
     "fat": ["hips", "chest"]}                       # joints that sit in the body's thickest parts

Positions are in the canonical frame used throughout autorig: +y up, +z the direction the character faces,
+x the character's own left; the feet at y = 0 and the whole figure one unit tall. Joints whose name ends in
``_end`` are tips (the crown of the head, the fingertips): they carry no bone of their own and exist so that the
chain before them knows where the limb ends.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import TemplateError

AUTO = "auto"   # the template name that asks for a template-free skeleton (autorig.extract)


@dataclass(frozen=True)
class ReducedSkeleton:
    """The template with its degree-2 chains collapsed: what the discrete embedding places.

    joints   [K] indices into the template's joints of the kept joints (root, branch points, leaves);
             reduced joint 0 is the root and parents come before children
    parents  [K] reduced index of each kept joint's parent, -1 for the root
    chains   [K] for each kept joint, the template joint indices from its reduced parent to it, both ends
             included (the root's chain is just itself)
    lengths  [K] template length of each chain (sum of its bone lengths); 0 for the root
    """
    joints: np.ndarray
    parents: np.ndarray
    chains: list[list[int]]
    lengths: np.ndarray


@dataclass(frozen=True)
class Template:
    """A template skeleton.

    name       template name
    names      [J] joint names
    parents    [J] int parent index, -1 for the root; parents come before children
    positions  [J, 3] rest positions in the canonical frame (x = left, y = up, z = front, height 1)
    symmetry   [(i, j)] mirror pairs of joint indices (i on the left, j on the right)
    feet       indices of the joints that should be lowest
    fat        indices of the joints that belong in the thickest parts of the body
    """
    name: str
    names: tuple[str, ...]
    parents: np.ndarray
    positions: np.ndarray
    symmetry: tuple[tuple[int, int], ...]
    feet: tuple[int, ...]
    fat: tuple[int, ...]

    @property
    def children(self) -> list[list[int]]:
        kids: list[list[int]] = [[] for _ in self.names]
        for j, p in enumerate(self.parents):
            if p >= 0:
                kids[p].append(j)
        return kids

    def mirror_of(self) -> np.ndarray:
        """[J] index of each joint's mirror image (itself for joints on the mid-plane)."""
        out = np.arange(len(self.names))
        for i, j in self.symmetry:
            out[i], out[j] = j, i
        return out

    def is_tip(self, j: int) -> bool:
        return self.names[j].endswith("_end")

    def reduced(self) -> ReducedSkeleton:
        """Collapse every joint with exactly one child (other than the root) into the chain through it."""
        kids = self.children
        keep = [j for j in range(len(self.names)) if self.parents[j] < 0 or len(kids[j]) != 1]
        index = {j: k for k, j in enumerate(keep)}
        parents, chains, lengths = [], [], []
        for j in keep:
            chain = [j]
            p = self.parents[j]
            while p >= 0 and p not in index:
                chain.append(p)
                p = self.parents[p]
            if p >= 0:
                chain.append(p)
            chain.reverse()
            parents.append(index[p] if p >= 0 else -1)
            chains.append(chain)
            seg = np.diff(self.positions[chain], axis=0)
            lengths.append(float(np.linalg.norm(seg, axis=1).sum()))
        return ReducedSkeleton(np.array(keep), np.array(parents), chains, np.array(lengths))


def _builtin_folder():
    """The folder of built-in templates: the installed ``autorig.templates`` package, or, when autorig runs
    from a source checkout that is not installed, the checkout's ``templates/``."""
    try:
        return resources.files("autorig.templates")
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[1] / "templates"


def builtin_names() -> list[str]:
    """Names of the templates that ship with autorig."""
    return sorted(p.name[:-5] for p in _builtin_folder().iterdir() if p.name.endswith(".json"))


def builtin_description(name: str) -> str:
    """The one-line description in a built-in template's file."""
    return json.loads(_builtin_folder().joinpath(name + ".json").read_text()).get("description", "")


def load_template(name_or_path: str | Path) -> Template:
    """A built-in template by name (``biped``) or a user's template file (``my_rig.json``)."""
    text_path = str(name_or_path)
    if text_path.endswith(".json") or Path(text_path).exists():
        path = Path(text_path)
        if not path.is_file():
            raise TemplateError(f"template file not found: {path}")
        try:
            data = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise TemplateError(f"template {path}: not valid JSON ({e})") from None
        return template_from_dict(data, default_name=path.stem, source=str(path))
    if text_path not in builtin_names():
        raise TemplateError(f"unknown template {text_path!r}; built-in templates: {', '.join(builtin_names())} "
                            f"(or give a path to a .json file)")
    data = json.loads(_builtin_folder().joinpath(text_path + ".json").read_text())
    return template_from_dict(data, default_name=text_path, source=text_path)


def template_from_dict(data: dict, default_name: str = "custom", source: str = "template") -> Template:
    """Validate a parsed template file and order its joints parents-first."""
    def bad(msg):
        return TemplateError(f"template {source}: {msg}")

    if not isinstance(data, dict) or not isinstance(data.get("joints"), list):
        raise bad('expected an object with a "joints" list')
    joints = data["joints"]
    if len(joints) < 2:
        raise bad("needs at least two joints")
    names, parent_names, positions = [], [], []
    for k, j in enumerate(joints):
        if not isinstance(j, dict) or not isinstance(j.get("name"), str) or not j["name"]:
            raise bad(f"joint #{k} has no name")
        pos = j.get("position")
        try:
            pos = [float(x) for x in pos]
        except (TypeError, ValueError):
            raise bad(f"joint {j['name']!r}: position must be three numbers") from None
        if len(pos) != 3 or not np.all(np.isfinite(pos)):
            raise bad(f"joint {j['name']!r}: position must be three finite numbers")
        names.append(j["name"])
        parent_names.append(j.get("parent"))
        positions.append(pos)
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise bad(f"duplicate joint names {dup}")
    roots = [n for n, p in zip(names, parent_names) if p is None]
    if len(roots) != 1:
        raise bad(f"needs exactly one root joint (parent null), found {len(roots)}")
    for n, p in zip(names, parent_names):
        if p is not None and p not in names:
            raise bad(f"joint {n!r} has unknown parent {p!r}")

    # Order parents before children; a cycle leaves joints unreached.
    order, frontier = [], [roots[0]]
    kids = {n: [c for c, p in zip(names, parent_names) if p == n] for n in names}
    while frontier:
        n = frontier.pop(0)
        order.append(n)
        frontier.extend(kids[n])
    if len(order) != len(names):
        raise bad(f"joints {sorted(set(names) - set(order))} are not connected to the root (cycle?)")
    old = {n: i for i, n in enumerate(names)}
    index = {n: i for i, n in enumerate(order)}
    parents = np.array([index[parent_names[old[n]]] if parent_names[old[n]] is not None else -1 for n in order])
    P = np.array([positions[old[n]] for n in order], dtype=float)
    bone = np.linalg.norm(P[1:] - P[parents[1:]], axis=1)
    if np.any(bone <= 1e-9):
        raise bad("two joints joined by a bone share one position")
    extent = np.ptp(P, axis=0).max()
    if extent <= 0:
        raise bad("all joints at one point")

    def indices(key):
        value = data.get(key, [])
        if not isinstance(value, list):
            raise bad(f'"{key}" must be a list')
        return value

    symmetry = []
    for pair in indices("symmetry"):
        if not (isinstance(pair, list) and len(pair) == 2 and all(p in index for p in pair)):
            raise bad(f"symmetry entry {pair!r} must name two joints")
        symmetry.append((index[pair[0]], index[pair[1]]))
    for key in ("feet", "fat"):
        unknown = [n for n in indices(key) if n not in index]
        if unknown:
            raise bad(f'"{key}" names unknown joints {unknown}')
    return Template(
        name=str(data.get("name", default_name)),
        names=tuple(order),
        parents=parents,
        positions=P,
        symmetry=tuple(symmetry),
        feet=tuple(index[n] for n in data.get("feet", [])),
        fat=tuple(index[n] for n in data.get("fat", [])),
    )
