"""Markers: where the user says some joints are, to fix a rig the embedding got wrong (``autorig MESH --markers FILE``).

A markers file is a JSON object of names to points ``[x, y, z]`` in the input mesh's own coordinates and units
(before any axis conversion)::

    {"chin": [0.0, 1.52, 0.09], "left_wrist": [0.71, 1.02, -0.02], "groin": [0.0, 0.86, 0.01]}

Each template documents a small marker set (``marker_names``), the points a person finds on a character at a
glance; every joint name of the template is accepted too (``accepted_names``):

- biped, humanoid: chin, left and right wrist, elbow and knee, and the groin;
- quadruped, horse: the four paws, the head, the tail base and the withers;
- centaur: the human half's chin, wrists and elbows, the four paws and the tail base.

A marker holds one joint (``marker_of``): a joint's own name, a wrist, elbow, knee, paw, the head or the tail base
puts that joint at the point. Three markers are points on the surface, and hold only what they say about the
joint inside (in the canonical frame: x the character's left, y up, z its front; offsets in heights):

- chin: the head joint (the skull's pivot) at the chin's height plus ``offset`` and on its mid-plane, as deep
  as the rig puts it;
- groin: the hips at the crotch's height plus ``offset`` and on its mid-plane, as deep as the rig puts them;
- withers: the neck's base (``neck``), over the top of the shoulders, front-to-back plus ``offset``; its
  height is the rig's.

How the rig honours them (``autorig.pipeline.rig``): the axes left "auto" are the markers' when they tell
(``marker_frame``); the discrete embedding puts each chain in the limb of the markers that hold a joint whole
(``autorig.embed.penalties``: a penalty for a path that misses one by more than 5 % of the height), so that the
rest of the skeleton is placed in those limbs as without markers; the marked joints are put at their markers
once the joints are in the rig's convention (where the user sees them), and kept there by each stage after it
(legs, head, tips, hands), so that the weights are made with them.

The offsets are the medians measured on the artists' rigs of the corpus and shared data
(``python benchmarks/markers.py --measure``): the hips 6.6 % of the height above the crotch (58 bipeds), the head
joint 1.9 % above the chin (58), the neck's base 5.8 % ahead of the point between the front shoulders (13
four-legged animals).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

MARKERS_BYTES = 1 << 20   # a markers file is a few lines: a larger one is refused before it is read
SIDE_TOLERANCE = 0.02     # heights: a pair's left marker this far on the character's right contradicts the axes
OUTSIDE_TOLERANCE = 0.02  # heights: a marker this far from the surface, outside it, is outside the mesh


@dataclass(frozen=True)
class Marker:
    """``joint`` (a template joint name) held at a marker; ``held``: the canonical axes it fixes (0 = x the
    character's left, 1 = y up, 2 = z its front); ``offset`` [3]: the joint minus the marker on those axes, in
    heights (the figure one unit tall)."""
    joint: str
    held: tuple[int, ...] = (0, 1, 2)
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


# The named markers. A wrist, elbow, knee or paw is that joint; the surface landmarks hold what they tell.
CHIN = Marker("head", (0, 1), (0.0, 0.019, 0.0))
GROIN = Marker("hips", (0, 1), (0.0, 0.066, 0.0))
WITHERS = Marker("neck", (0, 2), (0.0, 0.0, 0.058))

_BIPED = ("chin", "left_wrist", "right_wrist", "left_elbow", "right_elbow", "left_knee", "right_knee", "groin")
_FOUR_LEGS = ("front_left_paw", "front_right_paw", "back_left_paw", "back_right_paw", "head", "tail_base",
              "withers")
_CENTAUR = ("chin", "left_wrist", "right_wrist", "left_elbow", "right_elbow", "front_left_paw",
            "front_right_paw", "back_left_paw", "back_right_paw", "tail_base")
_LANDMARKS = {"chin": CHIN, "groin": GROIN, "withers": WITHERS}


def _names_of(template) -> tuple[str, ...]:
    if isinstance(template, str):
        from .template import load_template
        template = load_template(template)
    return tuple(template.names)


def marker_names(template) -> list[str]:
    """The template's documented marker set (a template name, path or ``Template``): the biped's or humanoid's
    for a template with wrists and knees, the four-legged set for one with four paws, the centaur's for one
    with both; a template with none of these (``--skeleton``-like custom ones) has only its joint names."""
    names = set(_names_of(template))
    wanted = (_CENTAUR if {"left_wrist", "front_left_paw"} <= names else
              _BIPED if {"left_wrist", "left_knee"} <= names else
              _FOUR_LEGS if "front_left_paw" in names else ())
    return [m for m in wanted if _LANDMARKS.get(m, Marker(m)).joint in names]


def accepted_names(template) -> list[str]:
    """Every name a markers file may use for ``template``: its marker set, then its joint names."""
    own = marker_names(template)
    return own + [n for n in _names_of(template) if n not in own]


def marker_of(name: str) -> Marker:
    """The ``Marker`` a name stands for: a landmark's, or its own joint's, held whole."""
    return _LANDMARKS.get(name, Marker(name))


def read_markers(path, template) -> dict[str, np.ndarray]:
    """{name: point [3]} of a markers file (``InputError``, one line, on anything wrong with it): a JSON object
    of names the template accepts (``accepted_names``) to three finite numbers. The points are the input's own
    coordinates; whether they lie in the mesh and agree on left and right is checked once the mesh is read
    (``check_markers``)."""
    from .input.limits import read_regular
    path = Path(path)
    try:
        text = read_regular(path, MARKERS_BYTES).decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"markers file not found: {path}") from None
    except UnicodeDecodeError:
        raise InputError(f"markers file {path.name}: not JSON (not UTF-8 text)") from None
    except OSError as error:
        raise InputError(f"markers file {path.name}: cannot read it ({error.strerror or error})") from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise InputError(f"markers file {path.name}: not JSON ({_short(error)})") from None
    return markers_from(data, template, path.name)


def markers_from(data, template, source: str = "markers") -> dict[str, np.ndarray]:
    """The checks of ``read_markers`` on an already parsed object (``RigOptions(markers={...})``)."""
    if not isinstance(data, dict):
        kind = {list: "a list", str: "a string", int: "a number", float: "a number", bool: "true or false",
                type(None): "null"}.get(type(data), type(data).__name__)
        raise InputError(f"{source}: must be a JSON object of marker names to [x, y, z], not {kind}")
    if not data:
        raise InputError(f"{source}: no markers in it")
    accepted = accepted_names(template)
    out = {}
    for name, value in data.items():
        if not isinstance(name, str) or name not in accepted:
            shown = ", ".join(accepted)
            raise InputError(f"{source}: unknown marker {_quoted(str(name))}; the template accepts: {shown}")
        point = _point(value)
        if point is None:
            raise InputError(f"{source}: marker {name!r} must be [x, y, z], three finite numbers, "
                             f"not {_shown(value)}")
        out[name] = point
    joints = {}
    for name in out:
        joint = marker_of(name).joint
        if joint in joints:
            raise InputError(f"{source}: markers {joints[joint]!r} and {name!r} both place the joint {joint!r}")
        joints[joint] = name
    return out


def check_markers(markers: dict[str, np.ndarray], vertices: np.ndarray, faces: np.ndarray, left: np.ndarray,
                  height: float, source: str = "markers") -> None:
    """``InputError`` when a marker lies outside the mesh (more than ``OUTSIDE_TOLERANCE`` of its ``height``
    from its surface) or the markers put left and right the wrong way round for ``left`` (the character's left
    as an input-coordinate direction, [3]): any pair of left and right markers more than ``SIDE_TOLERANCE``
    on the wrong side. Markers above, below or in front of one another are never a contradiction."""
    names = list(markers)
    points = np.array([markers[n] for n in names], dtype=np.float64)
    outside = outside_distances(points, vertices, faces) > OUTSIDE_TOLERANCE * height
    if outside.any():
        name = names[int(np.argmax(outside))]
        raise InputError(f"{source}: marker {name!r} at {_shown(markers[name].tolist())} lies outside the mesh "
                         f"(farther than {OUTSIDE_TOLERANCE:.0%} of its height from the surface)")
    left = np.asarray(left, dtype=np.float64)
    for name in names:
        other = mirror_name(name)
        if other is None or other not in markers or "left" not in name:
            continue
        side = float(np.dot(markers[name] - markers[other], left))
        if side < -SIDE_TOLERANCE * height:
            raise InputError(f"{source}: markers {name!r} and {other!r} are swapped: {name!r} lies on the "
                             f"character's right for these axes (check the markers, or --up/--front)")


def sides_agree(markers: dict[str, np.ndarray], left: np.ndarray, height: float) -> int:
    """How the markers' left-right pairs sit for ``left`` (an input-coordinate direction): +1 when every pair
    more than ``SIDE_TOLERANCE`` apart has its left marker on that side, -1 when every one has it on the other,
    0 when there are no such pairs or they disagree with one another."""
    signs = set()
    for name in markers:
        other = mirror_name(name)
        if other is None or other not in markers or "left" not in name:
            continue
        side = float(np.dot(markers[name] - markers[other], left))
        if abs(side) > SIDE_TOLERANCE * height:
            signs.add(1 if side > 0 else -1)
    return signs.pop() if len(signs) == 1 else 0


@dataclass(frozen=True)
class Held:
    """Joints held at markers, in a rig's canonical frame: ``index`` [M] template joint indices, ``mask`` [M, 3]
    the axes each holds, ``target`` [M, 3] where (meaningful where ``mask``), ``names`` [M] the markers'."""
    index: np.ndarray
    mask: np.ndarray
    target: np.ndarray
    names: tuple[str, ...]

    def apply(self, joints: np.ndarray) -> np.ndarray:
        """A copy of ``joints`` [J, 3] with the held joints' held coordinates at their markers. The others stay
        where the stages put them, in the limbs the embedding chose with the markers (moving them along with a
        marked joint made the other joints farther from the artists' on the corpus: ``benchmarks/markers.py``)."""
        out = np.array(joints, dtype=np.float64)
        out[self.index] = np.where(self.mask, self.target, out[self.index])
        return out

    def distances(self, joints: np.ndarray) -> np.ndarray:
        """[M] how far each held joint of ``joints`` [J, 3] lies from its marker, on the axes it holds."""
        return np.linalg.norm(np.where(self.mask, np.asarray(joints)[self.index] - self.target, 0.0), axis=1)

    @property
    def whole(self) -> np.ndarray:
        """[M] bool: the markers that hold all three coordinates of their joint."""
        return self.mask.all(axis=1)

    def to_spheres(self, centers: np.ndarray) -> np.ndarray:
        """[M, S] distance of each held joint's marker from each sphere centre [S, 3], on the axes it holds."""
        diff = centers[None, :, :] - self.target[:, None, :]
        return np.linalg.norm(np.where(self.mask[:, None, :], diff, 0.0), axis=2)



def held_joints(markers: dict[str, np.ndarray], template, to_canonical) -> Held:
    """The ``Held`` joints of ``markers`` (input coordinates) for ``template``, with ``to_canonical`` mapping
    input points [N, 3] into the rig's canonical frame (``PreparedMesh.to_canonical``)."""
    names = list(markers)
    points = to_canonical(np.array([markers[n] for n in names], dtype=np.float64).reshape(-1, 3))
    index, mask, target = [], [], []
    for name, point in zip(names, points):
        marker = marker_of(name)
        held = np.zeros(3, dtype=bool)
        held[list(marker.held)] = True
        index.append(list(template.names).index(marker.joint))
        mask.append(held)
        target.append(point + np.asarray(marker.offset) * held)
    return Held(np.array(index, dtype=np.int64), np.array(mask), np.array(target), tuple(names))


FRAME_MARGIN = 0.5   # the markers choose the axes left "auto" when the best frame fits at most half as badly


def marker_frame(markers: dict[str, np.ndarray], template, vertices: np.ndarray, up: str = "auto",
                 front: str = "auto") -> tuple[str, str]:
    """(up, front) with the axes left "auto" chosen by the markers when they tell: of the 24 frames (signed axes)
    that keep the given ones, those in which the markers' layout (centred, in heights of the mesh along its
    up) is nearest the template's joints' (each on the axes its marker holds), within twice the best fit; the
    up they all share, and the front they all share, else the axes as given. Left-right pairs of markers, when
    they all point one way (``left_axis``), keep only the frames whose left is that way: with the up given (or
    found), they say the front. Chin over knees tells up, a head before a tail base tells the front."""
    from .input.mesh import frame_rotation

    if (up != "auto" and front != "auto") or len(markers) < 2:
        return up, front
    names = list(markers)
    points = np.array([markers[n] for n in names], dtype=np.float64)
    wanted = np.array([template.positions[list(template.names).index(marker_of(n).joint)]
                       - np.asarray(marker_of(n).offset) for n in names])
    mask = np.zeros((len(names), 3), dtype=bool)
    for i, n in enumerate(names):
        mask[i, list(marker_of(n).held)] = True
    extent = np.ptp(vertices, axis=0)
    left = left_axis(markers)
    fits = []
    for u in ("x", "-x", "y", "-y", "z", "-z"):
        for f in ("x", "-x", "y", "-y", "z", "-z"):
            if u[-1] == f[-1] or (up != "auto" and u != up) or (front != "auto" and f != front):
                continue
            rotation = frame_rotation(u, f)
            if left is not None and not np.array_equal(rotation[0], left):
                continue
            height = float(extent["xyz".index(u[-1])]) or 1.0
            canonical = points @ rotation.T / height
            cost = 0.0
            for axis in range(3):
                rows = mask[:, axis]
                if rows.sum() >= 2:
                    a = canonical[rows, axis] - canonical[rows, axis].mean()
                    b = wanted[rows, axis] - wanted[rows, axis].mean()
                    cost += float(np.sum((a - b) ** 2))
            fits.append((cost, u, f))
    fits.sort()
    if not fits:
        return up, front
    close = [(u, f) for cost, u, f in fits if cost <= fits[0][0] / FRAME_MARGIN + 1e-9]
    return (close[0][0] if len({u for u, _ in close}) == 1 else up,
            close[0][1] if len({f for _, f in close}) == 1 else front)


def left_axis(markers: dict[str, np.ndarray]) -> np.ndarray | None:
    """The input axis [3] (a signed unit axis) the markers' left-right pairs say is the character's left: the
    sum of their left-minus-right vectors, when it lies within 37 degrees of one axis; else None."""
    total = np.zeros(3)
    for name in markers:
        other = mirror_name(name)
        if other is not None and other in markers and "left" in name:
            total += markers[name] - markers[other]
    length = float(np.linalg.norm(total))
    axis = int(np.argmax(np.abs(total)))
    if length == 0.0 or abs(total[axis]) < 0.8 * length:
        return None
    out = np.zeros(3)
    out[axis] = np.sign(total[axis])
    return out


def outside_distances(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """[M] how far each point lies outside the surface (0 inside it, by the generalized winding number)."""
    import igl

    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    P = np.ascontiguousarray(points, dtype=np.float64)
    inside = np.abs(igl.fast_winding_number(V, F, P)) >= 0.5
    squared = igl.point_mesh_squared_distance(P, V, F)[0]
    return np.where(inside, 0.0, np.sqrt(np.maximum(squared, 0.0)))


def mirror_name(name: str) -> str | None:
    """The other side's name of a left or right marker or joint (left_wrist <-> right_wrist), else None."""
    for a, b in (("left", "right"), ("right", "left")):
        if f"{a}_" in name:
            return name.replace(f"{a}_", f"{b}_", 1)
    return None


def _point(value) -> np.ndarray | None:
    """[3] float64 of three finite numbers (a JSON list; a tuple or array from Python), else None."""
    if isinstance(value, np.ndarray) and value.shape == (3,) and value.dtype.kind in "iuf":
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        return None
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        return None
    point = np.array([float(v) for v in value], dtype=np.float64)
    return point if all(math.isfinite(v) for v in point) else None


def _shown(value) -> str:
    text = json.dumps(value, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else repr(o))
    return text if len(text) <= 60 else text[:57] + "..."


def _quoted(name: str) -> str:
    from .errors import printable
    return repr(printable(name[:60] + ("..." if len(name) > 60 else "")))


def _short(error: Exception) -> str:
    return str(error).split("\n")[0][:100]
