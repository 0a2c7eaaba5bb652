"""Template skeletons: the joints, hierarchy and proportions that the embedding looks for in a mesh.

A template is a JSON file (see ``templates/biped.json``)::

    {"name": "biped",
     "joints": [{"name": "hips", "parent": null, "position": [0, 0.47, 0]}, ...],
     "symmetry": [["left_hip", "right_hip"], ...],   # mirror pairs (x -> -x)
     "feet": ["left_toe_end", "right_toe_end"],      # joints that should touch the ground
     "fat": ["hips", "chest"],                       # joints that sit in the body's thickest parts
     "penalty_weights": {"length": 1.0, ...},        # optional: the embedding's Γ (autorig.embed.penalties)
     "helpers": [{"name": "ik_knee_L", "parent": "hips", "offset": [0.1, 0.3, 0.6]}],  # optional
     "confidence": {...},                            # optional: a calibrated model (autorig.confidence)
     "head_tail": 1.2,                               # optional: weight of the head/tail cue (autorig.embed.orient)
     "head_bulk": 0.8,                               # optional: weight of the limb ends' bulk cue (autorig.embed.ends)
     "head_share": 1.5,                              # optional: weight of the weight-share cue (autorig.embed.ends)
     "head_crest": 0.5,                              # optional: weight of the crest cue (autorig.embed.orient)
     "head_toes": 2.0,                               # optional: weight of the feet's cue (autorig.embed.ends)
     "head_gap": 0.0,                                # optional: the most the embedding's front/back difference counts
     "fingers": true,                                # optional: read fingers off the hands (autorig.hands)
     "learned_from": {...}}                          # optional: what ``autorig learn`` made it from

Positions are in the canonical frame used throughout autorig: +y up, +z the direction the character faces,
+x the character's own left; the feet at y = 0 and the whole figure one unit tall. Joints whose name ends in
``_end`` are tips (the crown of the head, the fingertips): they carry no bone of their own and exist so that the
chain before them knows where the limb ends.

Helper joints (IK targets, prop sockets) carry no weight and take no part in the embedding: each rides along at
a fixed offset (template units, the canonical frame) from its parent joint, and is written with the rig.
``autorig learn`` (``autorig.learn``) makes templates from rigged characters, with their Γ and confidence model.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import TemplateError

AUTO = "auto"   # the template name that asks for a template-free skeleton (autorig.extract)
# The weights of orientation detection's head/tail cues (``autorig.embed.orient.weighted_cues``)
CUE_WEIGHTS = ("head_tail", "head_bulk", "head_share", "head_crest", "head_toes")

# The embedding's hand-set penalty weights (Γ), what a template without learned ``penalty_weights`` uses; each
# penalty is described in ``autorig.embed.penalties``, which weighs them. Set on the project's own mannequins.
PENALTY_WEIGHTS = {
    "length": 1.0,
    "direction": 0.8,
    "feet": 0.6,
    "symmetry": 0.6,
    "backtrack": 1.5,
    "overlap": 3.0,
    "fat": 1.0,
    "height": 0.0,
    "sides": 0.5,
}


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
class Helper:
    """A weightless joint: ``name``, ``parent`` (index of a template joint) and ``offset`` [3] from it in
    template units (the canonical frame, height 1)."""
    name: str
    parent: int
    offset: tuple[float, float, float]


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
    penalty_weights  {penalty: weight} of the embedding (Γ); None for the hand-set ``PENALTY_WEIGHTS``
    helpers    weightless joints riding at fixed offsets from template joints (``Helper``)
    confidence a calibrated confidence model (``autorig.confidence.ConfidenceModel.to_dict``), or None
    learned_from  what ``autorig learn`` made the template from (kept for the record), or None
    placement  {"alpha": [J], "extent": [3], "offset": [J, 3] (optional), "neck": fraction (optional)}: how
               far each joint is pulled towards the stretched template, and moved by the learned offset; the
               examples' mean neck height for the stretch about the neck (``autorig.embed.placement``), or None
    head_tail  how much the shape's head/tail cue weighs in orientation detection (``autorig.embed.orient``), in
               penalty units; 0 leaves front and back to the embedding alone
    head_bulk  how much the limb ends' bulk cue (``autorig.embed.ends``) weighs beside it, in penalty units
    head_share how much the weight-share cue (``ends.weight_share_cue``) weighs beside them, in penalty units
    head_crest how much the crest cue (``orient.crest_cue``) weighs beside them, in penalty units
    head_toes  how much the feet's cue (``ends.toes_cue``: which way the toes point) weighs beside them, in
               penalty units
    head_gap   the most the embedding's penalty difference between two frames that share up and face opposite
               ways counts in detection (``autorig.embed.orient``), in penalty units; None: all of it
    conventions  {name: {"offsets": [J, 3], ...}}: where each source of the examples puts its joints relative
               to the shared anatomy (``autorig.embed.convention``), or None
    default_convention  the convention a rig takes unless told (a key of ``conventions``), or None
    fingers    whether rigs of it get fingers read off their hands (``autorig.hands``); default False
    legs       {joint name: {"height": [3] or "ratio": [3], "offset": [2]}}: where a four-legged animal's leg joints sit on its
               legs as the mesh shows them (``autorig.readoff.legs``), or None
    """
    name: str
    names: tuple[str, ...]
    parents: np.ndarray
    positions: np.ndarray
    symmetry: tuple[tuple[int, int], ...]
    feet: tuple[int, ...]
    fat: tuple[int, ...]
    penalty_weights: dict | None = field(default=None, compare=False, hash=False)
    helpers: tuple["Helper", ...] = ()
    confidence: dict | None = field(default=None, compare=False, hash=False)
    learned_from: dict | None = field(default=None, compare=False, hash=False)
    placement: dict | None = field(default=None, compare=False, hash=False)
    head_tail: float = field(default=0.0, compare=False, hash=False)
    head_bulk: float = field(default=0.0, compare=False, hash=False)
    head_share: float = field(default=0.0, compare=False, hash=False)
    head_crest: float = field(default=0.0, compare=False, hash=False)
    head_toes: float = field(default=0.0, compare=False, hash=False)
    head_gap: float | None = field(default=None, compare=False, hash=False)
    conventions: dict | None = field(default=None, compare=False, hash=False)
    default_convention: str | None = field(default=None, compare=False, hash=False)
    fingers: bool = field(default=False, compare=False, hash=False)
    legs: dict | None = field(default=None, compare=False, hash=False)

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

    def with_helpers(self, joints: np.ndarray) -> tuple[list[str], np.ndarray, np.ndarray]:
        """(names [J + H], parents [J + H], positions [J + H, 3]): ``joints`` [J, 3] (canonical frame) with
        the helper joints appended, each at its offset from its parent."""
        names = list(self.names) + [h.name for h in self.helpers]
        parents = np.concatenate([self.parents, np.array([h.parent for h in self.helpers], dtype=np.int64)])
        extra = np.array([joints[h.parent] + np.asarray(h.offset) for h in self.helpers]).reshape(-1, 3)
        return names, parents.astype(np.int64), np.vstack([joints, extra])

    def to_dict(self, description: str = "") -> dict:
        """The template as its JSON file holds it (``template_from_dict`` reads it back)."""
        data = {"name": self.name}
        if description:
            data["description"] = description
        data["frame"] = "x = the character's left, y = up, z = the way it faces; feet at y = 0; 1 unit tall"
        data["joints"] = [{"name": n, "parent": self.names[p] if p >= 0 else None,
                           "position": [round(float(v), 4) for v in self.positions[j]]}
                          for j, (n, p) in enumerate(zip(self.names, self.parents))]
        data["symmetry"] = [[self.names[i], self.names[j]] for i, j in self.symmetry]
        data["feet"] = [self.names[j] for j in self.feet]
        data["fat"] = [self.names[j] for j in self.fat]
        if self.penalty_weights is not None:
            data["penalty_weights"] = {k: round(float(v), 5) for k, v in self.penalty_weights.items()}
        if self.helpers:
            data["helpers"] = [{"name": h.name, "parent": self.names[h.parent],
                                "offset": [round(float(v), 4) for v in h.offset]} for h in self.helpers]
        if self.placement is not None:
            data["placement"] = {"alpha": [round(float(a), 4) for a in self.placement["alpha"]],
                                 "extent": [round(float(e), 4) for e in self.placement["extent"]]}
            if self.placement.get("neck") is not None:
                data["placement"]["neck"] = round(float(self.placement["neck"]), 4)
            if self.placement.get("offset") is not None:
                data["placement"]["offset"] = [[round(float(v), 4) for v in row]
                                               for row in self.placement["offset"]]
        for key in CUE_WEIGHTS:
            if getattr(self, key):
                data[key] = round(float(getattr(self, key)), 4)
        if self.head_gap is not None:
            data["head_gap"] = round(float(self.head_gap), 4)
        if self.fingers:
            data["fingers"] = True
        if self.conventions:
            from .embed.convention import conventions_dict
            data["default_convention"] = self.default_convention
            data["conventions"] = conventions_dict(self)
        if self.fingers:
            data["fingers"] = True
        if self.legs:
            data["legs"] = self.legs
        if self.confidence is not None:
            data["confidence"] = self.confidence
        if self.learned_from is not None:
            data["learned_from"] = self.learned_from
        return data

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


def base_description(name_or_path: str | Path) -> str:
    """The description in a template file (a built-in's by name), without any "Learned ..." sentence."""
    path = Path(str(name_or_path))
    try:
        text = path.read_text() if path.suffix == ".json" else _builtin_folder().joinpath(f"{path}.json").read_text()
        description = str(json.loads(text).get("description", ""))
    except (OSError, ValueError):
        return ""
    return description.split(" Learned by autorig learn")[0]


def template_json(data: dict) -> str:
    """A template's JSON text as the built-in files are laid out: one joint, pair or helper per line."""
    lines = ["{"]
    items = list(data.items())
    for n, (key, value) in enumerate(items):
        comma = "," if n < len(items) - 1 else ""
        if key in ("joints", "helpers", "symmetry") and isinstance(value, list) and value:
            rows = [f"  {json.dumps(v)}" for v in value]
            lines.append(f" {json.dumps(key)}: [\n" + ",\n".join(rows) + f"\n ]{comma}")
        elif key == "conventions" and isinstance(value, dict) and value:
            rows = [f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in value.items()]
            lines.append(f" {json.dumps(key)}: {{\n" + ",\n".join(rows) + f"\n }}{comma}")
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value)}{comma}")
    return "\n".join(lines) + "\n}\n"


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
        except RecursionError:
            raise TemplateError(f"template {path}: the JSON nests too deeply") from None
        return template_from_dict(data, default_name=path.stem, source=str(path))
    if text_path not in builtin_names():
        raise TemplateError(f"unknown template {text_path!r}; built-in templates: {', '.join(builtin_names())}, "
                            f"or auto (a skeleton from the mesh's own shape), or a path to a .json file")
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
        except (TypeError, ValueError, OverflowError):
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
    penalty_weights = _penalty_weights(data.get("penalty_weights"), bad)
    helpers = []
    for k, h in enumerate(indices("helpers")):
        if not isinstance(h, dict) or not isinstance(h.get("name"), str) or h.get("parent") not in index:
            raise bad(f"helper #{k} needs a name and the name of a template joint as its parent")
        try:
            offset = tuple(float(v) for v in h.get("offset"))
        except (TypeError, ValueError, OverflowError):
            offset = ()
        if len(offset) != 3 or not np.all(np.isfinite(offset)):
            raise bad(f"helper {h['name']!r}: offset must be three finite numbers")
        if h["name"] in index or any(h["name"] == other.name for other in helpers):
            raise bad(f"helper {h['name']!r} has the name of another joint")
        helpers.append(Helper(h["name"], index[h["parent"]], offset))
    cue_weights = {key: data.get(key, 0.0) for key in CUE_WEIGHTS}
    head_gap = data.get("head_gap")
    for key, value in (*cue_weights.items(), *((("head_gap", head_gap),) if head_gap is not None else ())):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < float("inf"):
            raise bad(f'"{key}" must be a number >= 0')
    fingers = data.get("fingers", False)
    if not isinstance(fingers, bool):
        raise bad('"fingers" must be true or false')
    confidence = data.get("confidence")
    if confidence is not None and not isinstance(confidence, dict):
        raise bad('"confidence" must be an object')
    placement = data.get("placement")
    if placement is not None:
        alpha = placement.get("alpha") if isinstance(placement, dict) else None
        extent = placement.get("extent") if isinstance(placement, dict) else None
        if (not isinstance(alpha, list) or len(alpha) != len(names)
                or not all(isinstance(a, (int, float)) and 0 <= a <= 1 for a in alpha)
                or not isinstance(extent, list) or len(extent) != 3
                or not all(isinstance(e, (int, float)) and e > 0 for e in extent)):
            raise bad(f'"placement" needs "alpha": {len(names)} numbers in [0, 1], one per joint, and '
                      f'"extent": three positive numbers')
        offset = placement.get("offset")
        if offset is not None and not (isinstance(offset, list) and len(offset) == len(names) and all(
                isinstance(row, list) and len(row) == 3 and all(isinstance(v, (int, float)) and not isinstance(
                    v, bool) and abs(v) < 10 for v in row) for row in offset)):
            raise bad(f'"placement" "offset" must be {len(names)} rows of three numbers, one per joint')
        neck = placement.get("neck")
        if neck is not None and not (isinstance(neck, (int, float)) and not isinstance(neck, bool)
                                     and 0.3 < neck < 1):
            raise bad('"placement" "neck" must be a number between 0.3 and 1 (a fraction of the height)')
        # alpha and offset are listed in the file's joint order; the template's is parents-first.
        placement = {"alpha": [float(alpha[old[n]]) for n in order], "extent": [float(e) for e in extent]}
        if offset is not None:
            placement["offset"] = [[float(v) for v in offset[old[n]]] for n in order]
        if neck is not None:
            placement["neck"] = float(neck)
    from .embed.convention import parse_conventions
    conventions, default_convention = parse_conventions(data.get("conventions"), names, order,
                                                        data.get("default_convention"), bad)
    from .readoff.legs import parse_legs
    legs = parse_legs(data.get("legs"), names, bad)
    return Template(
        name=str(data.get("name", default_name)),
        names=tuple(order),
        parents=parents,
        positions=P,
        symmetry=tuple(symmetry),
        feet=tuple(index[n] for n in data.get("feet", [])),
        fat=tuple(index[n] for n in data.get("fat", [])),
        penalty_weights=penalty_weights,
        helpers=tuple(helpers),
        confidence=confidence,
        learned_from=data.get("learned_from"),
        placement=placement,
        head_tail=float(cue_weights["head_tail"]),
        head_bulk=float(cue_weights["head_bulk"]),
        head_share=float(cue_weights["head_share"]),
        head_crest=float(cue_weights["head_crest"]),
        head_toes=float(cue_weights["head_toes"]),
        head_gap=float(head_gap) if head_gap is not None else None,
        conventions=conventions,
        default_convention=default_convention,
        fingers=fingers,
        legs=legs,
    )


def _penalty_weights(value, bad) -> dict | None:
    """A template's Γ, checked: known penalty names, finite non-negative weights; missing ones keep the
    hand-set default (``PENALTY_WEIGHTS``)."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise bad('"penalty_weights" must be an object {penalty: weight}')
    unknown = sorted(set(value) - set(PENALTY_WEIGHTS))
    if unknown:
        raise bad(f'"penalty_weights" names unknown penalties {unknown}; known: {", ".join(PENALTY_WEIGHTS)}')
    out = dict(PENALTY_WEIGHTS)
    for k, v in value.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
            raise bad(f'penalty weight {k!r} must be a finite number >= 0')
        out[k] = float(v)
    return out
