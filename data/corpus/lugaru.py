#!/usr/bin/env python3
"""Convert the rigged characters of Lugaru (Debian ``lugaru-data``) into autorig's corpus layout.

Lugaru's humanoid rabbit and wolf are biped bodies rigged to a 20-joint "muscle" skeleton: every mesh vertex
belongs to exactly one muscle (a segment between two joints), and moves rigidly with it. Data licence:
CC-BY-SA-3.0, (c) 2003, 2010 Wolfire Games (Debian copyright, ``Files: Data/*``).

The script fetches the package itself: ``apt-get download lugaru-data`` into a temporary directory (no root
needed for that, no installation) and ``dpkg -x`` to unpack it; ``--deb FILE`` uses an already downloaded .deb.

    python data/corpus/lugaru.py [--out DIR] [--variants] [--deb FILE]

writes ``DIR/lugaru_<name>/`` (``mesh.obj``, ``joints.json``, ``weights.npz``) and appends a section to
``DIR/MANIFEST.md``. DIR defaults to ``../corpus`` relative to the repository root.

File formats (learnt from Lugaru's GPL source, Source/Graphic/Models.cpp and Source/Animation/{Skeleton,Joint,
Muscle}.cpp; everything big-endian, bools one byte):

``Models/*.solid``  int16 vertex count, int16 triangle count; vertices as 3 float32; per triangle 6 int16
                    (corners at 0, 2, 4) + 3 float32 u + 3 float32 v.
``Skeleton/*``      int32 joint count; per joint: position 3f, length f, mass f, hasparent b, locked b,
                    modelnum i, visible b, sametwist b, label i, hasgun i, lower b, parent i;
                    int32 muscle count; per muscle: length, targetlength, minlength, maxlength, strength (5f),
                    type i, vertex count i, vertex indices i..., visible b, joint1 i, joint2 i;
                    forward joints 3i, low forward joints 3i.

The game rotates the .solid vertices by 180 degrees about x and scales them by 0.04 (Skeleton::Load) before they
meet the skeleton's joint positions; after that the bind frame is +y up, the characters face +z and their
"left*" joints are on +x, i.e. already the corpus frame (right-handed, +x = the character's left).
"""
from __future__ import annotations

import argparse
import json
import shutil
import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np

PACKAGE = "lugaru-data"
DATA = "usr/share/games/lugaru"
LICENSE = ("CC-BY-SA-3.0, (c) 2003, 2010 Wolfire Games (Debian lugaru-data copyright: 'Files: Data/* / "
           "Copyright: 2003, 2010 Wolfire Games <http://www.wolfire.com> / License: CC-BY-SA-3.0'); "
           "derived files are under the same licence")

# Joint labels: Lugaru's ``enum bodypart`` (Source/Animation/Joint.hpp), in order.
LABELS = ["head", "neck", "leftshoulder", "leftelbow", "leftwrist", "lefthand",
          "rightshoulder", "rightelbow", "rightwrist", "righthand", "abdomen", "lefthip", "righthip", "groin",
          "leftknee", "leftankle", "leftfoot", "rightknee", "rightankle", "rightfoot"]

# The files carry no hierarchy (``hasparent`` is false everywhere: the skeleton is a mass-spring ragdoll), so
# we root a tree at the pelvis ("groin") and follow the rigid "boneconnect" muscles; each edge below is such a
# muscle in both figures (checked when reading).
PARENT = {"groin": None, "abdomen": "groin", "neck": "abdomen", "head": "neck",
          "leftshoulder": "neck", "leftelbow": "leftshoulder", "leftwrist": "leftelbow", "lefthand": "leftwrist",
          "rightshoulder": "neck", "rightelbow": "rightshoulder", "rightwrist": "rightelbow",
          "righthand": "rightwrist",
          "lefthip": "groin", "leftknee": "lefthip", "leftankle": "leftknee", "leftfoot": "leftankle",
          "righthip": "groin", "rightknee": "righthip", "rightankle": "rightknee", "rightfoot": "rightankle"}

# Template key -> Lugaru joint. Lugaru has one joint between pelvis and neck ("abdomen", at the navel/lower
# chest), used as spine; chest has no joint. "foot" is the front of the foot (the ball/toes), "hand" the
# fingertips end of the hand.
BIPED_MAP = {"hips": "groin", "spine": "abdomen", "chest": None, "neck": "neck", "head": "head",
             "left_shoulder": "leftshoulder", "left_elbow": "leftelbow", "left_wrist": "leftwrist",
             "right_shoulder": "rightshoulder", "right_elbow": "rightelbow", "right_wrist": "rightwrist",
             "left_hip": "lefthip", "left_knee": "leftknee", "left_ankle": "leftankle", "left_toe": "leftfoot",
             "right_hip": "righthip", "right_knee": "rightknee", "right_ankle": "rightankle",
             "right_toe": "rightfoot"}

# name -> (skeleton file, body files, description). Body2-7 / Wolf2-7 are morph variants of the same mesh
# (same vertices and skinning, 19-138 of the vertices moved: ears, hands, belly/tail); they are exported only
# with --variants because they would weight one body shape several times in a learned average.
CHARACTERS = {
    "rabbit": ("Skeleton/BasicFigure", ["Models/Body.solid"] + [f"Models/Body{i}.solid" for i in range(2, 8)],
               "humanoid rabbit (player Turner and the other rabbits; long upright ears, tail)"),
    "wolf": ("Skeleton/BasicFigureWolf", ["Models/Wolf.solid"] + [f"Models/Wolf{i}.solid" for i in range(2, 8)],
             "humanoid wolf (digitigrade legs, muzzle, tail)"),
}
GAME_SCALE = 0.04  # Skeleton::Load: model[i].Scale(.04, .04, .04)


class Reader:
    """Sequential big-endian reader over bytes."""

    def __init__(self, data: bytes):
        self.data, self.at = data, 0

    def take(self, fmt: str):
        fmt = ">" + fmt
        out = struct.unpack_from(fmt, self.data, self.at)
        self.at += struct.calcsize(fmt)
        return out


def read_solid(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A .solid model in game units: vertices [V, 3] float64 (rotated 180 deg about x and scaled by 0.04, as
    the game does) and triangles [F, 3] int64."""
    r = Reader(path.read_bytes())
    nv, nt = r.take("hh")
    v = np.array(r.take(f"{3 * nv}f"), dtype=np.float64).reshape(nv, 3)
    tris = []
    for _ in range(nt):
        corners = r.take("6h")
        r.take("6f")  # texture coordinates, not needed
        tris.append(corners[0::2])
    if r.at != len(r.data):
        raise ValueError(f"{path}: {len(r.data) - r.at} bytes left over; not a .solid model")
    v = v * np.array([1.0, -1.0, -1.0]) * GAME_SCALE  # DoRotation(v, 180, 0, 0): y -> -y, z -> -z
    return v, np.array(tris, dtype=np.int64)


def read_skeleton(path: Path) -> tuple[list[dict], list[dict]]:
    """Joints [{label, position [3]}] and muscles [{joints (a, b), type, visible, vertices [n]}] of a
    Skeleton file (positions already in the game's bind frame)."""
    r = Reader(path.read_bytes())
    joints = []
    for _ in range(r.take("i")[0]):
        x, y, z, _length, _mass = r.take("5f")
        _hasparent, _locked, _modelnum, _visible, _sametwist, label, _hasgun, _lower, _parent = r.take("??i??ii?i")
        joints.append({"label": LABELS[label], "position": [x, y, z]})
    muscles = []
    for _ in range(r.take("i")[0]):
        *_lengths, kind, n = r.take("5fii")
        vertices = r.take(f"{n}i")
        visible, a, b = r.take("?ii")
        muscles.append({"joints": (a, b), "type": kind, "visible": visible, "vertices": vertices})
    r.take("6i")  # forward / low-forward joint triples (for the game's facing computation)
    if r.at != len(r.data):
        raise ValueError(f"{path}: {len(r.data) - r.at} bytes left over; not a Lugaru skeleton")
    return joints, muscles


def rig(skeleton: Path, body: Path):
    """One character in corpus form.

    Returns (vertices [V, 3], faces [F, 3], names [J], parents [J] (names or None), positions [J, 3],
    weights [V, J] float32 one-hot). Joint order = PARENT's order (root first)."""
    joints, muscles = read_skeleton(skeleton)
    V, F = read_solid(body)
    names = list(PARENT)
    index_of_file = {j["label"]: i for i, j in enumerate(joints)}
    if sorted(index_of_file) != sorted(names):
        raise ValueError(f"{skeleton}: joints {sorted(index_of_file)} are not Lugaru's 20 body parts")
    positions = np.array([joints[index_of_file[n]]["position"] for n in names], dtype=np.float64)
    col = {n: k for k, n in enumerate(names)}
    # Rigid muscles (type 0 = boneconnect) as label pairs, to check that our tree only uses real bones.
    bones = {frozenset((joints[m["joints"][0]]["label"], joints[m["joints"][1]]["label"]))
             for m in muscles if m["type"] == 0}
    for child, parent in PARENT.items():
        if parent is not None and frozenset((child, parent)) not in bones:
            raise ValueError(f"{skeleton}: no rigid muscle {parent}-{child}")
    # Skinning: Skeleton::Load gives vertex i to the LAST muscle listing it; the vertex then moves rigidly with
    # that muscle. A muscle is the bone between a joint and its parent in our tree, and by the glTF convention
    # (a joint owns its outgoing bones) its vertices go to the parent end. So the head muscle (neck-head)
    # belongs to "neck" and the leaf joints head/hand/foot get no vertices.
    owner = np.full(len(V), -1, dtype=np.int64)
    for m in muscles:
        a, b = (joints[j]["label"] for j in m["joints"])
        if PARENT[b] == a:
            upper = a
        elif PARENT[a] == b:
            upper = b
        else:  # a brace (e.g. shoulder-to-shoulder): must not carry skin
            if m["vertices"]:
                raise ValueError(f"{skeleton}: muscle {a}-{b} has vertices but is no bone of the tree")
            continue
        for v in m["vertices"]:
            if v < len(V):  # the game ignores indices beyond the model, so do we
                owner[v] = col[upper]
    if (owner < 0).any():
        raise ValueError(f"{body}: {int((owner < 0).sum())} vertices belong to no muscle")
    W = np.zeros((len(V), len(names)), dtype=np.float32)
    W[np.arange(len(V)), owner] = 1.0
    parents = [PARENT[n] for n in names]
    return V, F, names, parents, positions, W


def weld(V, F, W):
    """Merge vertices with identical positions (weights averaged, faces that collapse dropped).
    Returns (V [V', 3], F [F', 3], W [V', J], info)."""
    key, inverse = np.unique(np.round(V, 6), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    Vw = np.zeros((len(key), 3))
    Ww = np.zeros((len(key), W.shape[1]))
    count = np.bincount(inverse, minlength=len(key)).astype(float)
    np.add.at(Vw, inverse, V)
    np.add.at(Ww, inverse, W)
    Vw /= count[:, None]
    Ww /= count[:, None]
    disagree = int((Ww.max(axis=1) < 1 - 1e-6).sum())
    Fw = inverse[F]
    good = (Fw[:, 0] != Fw[:, 1]) & (Fw[:, 1] != Fw[:, 2]) & (Fw[:, 0] != Fw[:, 2])
    # Duplicate triangles (same corner set) would make the surface non-manifold; keep the first.
    _, first = np.unique(np.sort(Fw[good], axis=1), axis=0, return_index=True)
    Fw = Fw[good][np.sort(first)]
    info = {"source_vertices_before_weld": len(V), "weld_merged_vertices": len(V) - len(key),
            "weld_vertices_with_mixed_owners": disagree,
            "weld_dropped_degenerate_faces": int((~good).sum()),
            "weld_dropped_duplicate_faces": int(good.sum() - len(Fw))}
    return Vw, Fw, Ww.astype(np.float32), info


def orient_outward(V, F):
    """Faces flipped, if needed, so that the signed volume is positive (normals outward).
    Returns (F, flipped, signed volume before)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    vol = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
    return (F[:, ::-1].copy(), True, vol) if vol < 0 else (F, False, vol)


def components(nv, F) -> int:
    """Number of connected pieces of the triangle mesh."""
    parent = np.arange(nv)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for a, b, c in F:
        for x, y in ((a, b), (b, c)):
            rx, ry = find(x), find(y)
            if rx != ry:
                parent[rx] = ry
    return len({find(i) for i in np.unique(F)})


def write_obj(path: Path, V, F, header: str):
    lines = [f"# {header}"] + [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in V]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")


def fetch(deb: Path | None, work: Path) -> tuple[Path, str]:
    """The unpacked package root and its version; downloads the .deb with apt-get unless given."""
    if deb is None:
        subprocess.run(["apt-get", "download", PACKAGE], cwd=work, check=True, capture_output=True)
        deb = next(work.glob(f"{PACKAGE}_*.deb"))
    version = subprocess.run(["dpkg-deb", "-f", str(deb), "Version"], check=True, capture_output=True,
                             text=True).stdout.strip()
    root = work / "root"
    subprocess.run(["dpkg", "-x", str(deb), str(root)], check=True)
    return root, version


def convert(root: Path, version: str, out: Path, variants: bool) -> list[dict]:
    """Write every character folder; returns one summary row per character."""
    data = root / DATA
    rows = []
    for creature, (skeleton_file, body_files, description) in CHARACTERS.items():
        for k, body_file in enumerate(body_files if variants else body_files[:1]):
            name = f"lugaru_{creature}" if k == 0 else f"lugaru_{creature}_{Path(body_file).stem.lower()}"
            V, F, names, parents, P, W = rig(data / skeleton_file, data / body_file)
            V, F, W, weld_info = weld(V, F, W)
            F, flipped, vol = orient_outward(V, F)
            folder = out / name
            folder.mkdir(parents=True, exist_ok=True)
            write_obj(folder / "mesh.obj", V, F, f"{name}: Lugaru {body_file} ({PACKAGE} {version}), {LICENSE}")
            np.savez_compressed(folder / "weights.npz", weights=W, joint_names=np.array(names))
            height = float(V[:, 1].max() - V[:, 1].min())
            meta = {
                "name": name,
                "joints": [{"name": n, "parent": p, "position": [float(x) for x in pos]}
                           for n, p, pos in zip(names, parents, P)],
                "biped_map": BIPED_MAP,
                "up_axis": "+y", "front_axis": "+z", "left_axis": "+x",
                "height_along_up": height,
                "category": "biped",
                "source_group": "lugaru",
                "convention": "lugaru",
                "rest_pose": "the game's bind pose: standing upright, arms hanging straight down beside the "
                             "body, legs nearly straight, feet pointing forward",
                "source": f"Debian {PACKAGE} {version}: {DATA}/{body_file} (mesh), {DATA}/{skeleton_file} "
                          "(joints and muscles)",
                "license": LICENSE,
                "notes": (f"{description}. Lugaru's skeleton is a 20-joint ragdoll without a hierarchy; parents "
                          "are ours (tree rooted at groin along rigid muscles). Skinning is rigid: each vertex "
                          "follows one muscle, given to the muscle's upper joint (the neck owns the head). "
                          "head = centre of the skull; hand/foot = tip-side ends of hand and foot (foot joint at "
                          "the ball of the foot); no chest joint. Height includes the ears. Coordinates = the "
                          "game's bind frame (.solid vertices rotated 180 deg about x, scaled 0.04), game units."
                          + (f" Morph variant {Path(body_file).name} of the same mesh." if k else "")),
                "weights_are_ground_truth": True,
                "weights_note": "rigid one-muscle-per-vertex skinning from the Skeleton file's muscle vertex lists",
                **weld_info,
                "faces_flipped_to_outward": flipped,
                "signed_volume_before_flip": vol,
                "mesh_stats": {"vertices": len(V), "faces": len(F), "components": components(len(V), F),
                               "bbox_min": V.min(0).tolist(), "bbox_max": V.max(0).tolist()},
            }
            (folder / "joints.json").write_text(json.dumps(meta, indent=1) + "\n")
            rows.append({"name": name, "body": body_file, "skeleton": skeleton_file, "V": len(V), "F": len(F),
                         "components": meta["mesh_stats"]["components"], "desc": description})
            print(f"{name}: {len(V)} vertices, {len(F)} faces, height {height:.3f}")
    return rows


def append_manifest(out: Path, rows: list[dict], version: str):
    table = "\n".join(f"| {r['name']} | biped | {r['body']} | {r['skeleton']} | {r['V']} | {r['F']} | "
                      f"{r['components']} | 18/19 | {r['desc']} |" for r in rows)
    text = f"""
## Lugaru (Debian {PACKAGE} {version})

Source: Debian package **{PACKAGE} {version}**, `{DATA}/Models/*.solid` (meshes) and `{DATA}/Skeleton/*`
(joints + muscles), read with `data/corpus/lugaru.py` (formats from Lugaru's GPL source, osslugaru/lugaru).
Licence: {LICENSE}.

How made: the game's load transform (180 deg about x, scale 0.04) puts the mesh on the skeleton's bind
joints; frame +y up, +z front, +x = character's left (game units). Parents are ours (Lugaru's ragdoll has
none): a tree rooted at `groin` along rigid muscles. Weights are the game's rigid skinning (each vertex follows
one muscle), given to the muscle's upper joint. Mesh welded by position, faces outward. Map: hips=groin,
spine=abdomen, chest=null, neck, head (mid-skull), shoulder/elbow/wrist, hip/knee/ankle, toe=foot.
Morph variants Body2-7 / Wolf2-7 (ears, hands, belly) only with `--variants`; low-poly BodyLow/WolfLow and
Rabbit.solid (unrigged) not used.

| name | category | mesh | skeleton | vertices | faces | components | joints mapped | notes |
|---|---|---|---|---|---|---|---|---|
{table}
"""
    # Re-running replaces our section instead of appending a second copy; other sources' sections stay.
    path = out / "MANIFEST.md"
    old = "\n" + (path.read_text() if path.exists() else "")
    start = old.find("\n## Lugaru (")
    if start >= 0:
        end = old.find("\n## ", start + 1)
        old = old[:start] + (old[end:] if end >= 0 else "")
    old = old.strip("\n")
    path.write_text(old + "\n" + text if old else text.lstrip("\n"))


def main():
    repo = Path(__file__).resolve().parents[2]
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=repo.parent / "corpus", help="corpus folder (default: %(default)s)")
    ap.add_argument("--deb", type=Path, help="use this lugaru-data .deb instead of downloading it")
    ap.add_argument("--variants", action="store_true", help="also write the morph variants Body2-7 / Wolf2-7")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="lugaru_"))
    try:
        root, version = fetch(args.deb.resolve() if args.deb else None, work)
        rows = convert(root, version, args.out, args.variants)
        append_manifest(args.out, rows, version)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
