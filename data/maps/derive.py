#!/usr/bin/env python3
"""Template maps for rigged glTF characters without one (``shared/data/more``), read off the skeleton's geometry.

    python data/maps/derive.py [--more ../shared/data/more] [--out data/maps] [--check]

Each ``model.glb`` (+y up, facing +z, +x the character's left, as its MANIFEST says) is read with its joints and
skin weights, and its joints are given template names by where they lie, not by their names (the wipf's and the
mooq's ``_l`` bones lie on the character's right):

four-legged (``quadruped_map``)
    legs: the weighted joints off the mid-plane and below the trunk, with the ones off the mid-plane above them in
    the hierarchy, split into front and back at the widest gap along z, and into left (+x) and right; in each leg
    the highest joint is the shoulder or hip, and the others, top down, go in order to the template joints
    (elbow, wrist, paw / knee, ankle, paw) whose height above the ground, as a share of the leg's, is nearest
    theirs (the shares of the built-in quadruped template; a joint more than the template has stays unnamed);
    head: of the weighted mid-plane joints whose skin lies in front of the front legs, the one with most skin;
    hips / chest: the mid-plane joints nearest the middle of the hind / front legs' tops; spine: the mid-plane
    joint nearest half-way between them, if one lies between; neck: a joint on the path from the chest to the
    head; tail base: of the mid-plane joints behind the hind legs, the one nearest them.
two-legged (``biped_map``)
    feet: on each side the lowest weighted joint; arms: on each side the weighted joint farthest out along x
    above the hips; on each one's path from the root: the first joint off the mid-plane is the hip or shoulder,
    the wrist is the first joint after the elbow where the hand branches into fingers (else the path's end), the
    elbow and knee the joints between; ankle the joint after the knee, toe the one after it if it has children
    (a ball before the toe tip); head: the mid-plane joint above the shoulders with most skin, neck its parent
    when that lies above the shoulders' middle, chest the highest mid-plane joint between hips and shoulders,
    hips the mid-plane joint nearest the legs' tops.

Ties (two joints at one place, as the wipf's ``hip_l`` and ``hip_r``) go to the one nearer the root, then the
first in the file. ``--check`` exits 1 when a committed map differs from what the geometry gives. Characters
whose kind no template fits (the bat, the squid) are listed and skipped.
"""
from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

# kind of each character in shared/data/more (its MANIFEST.txt's "kind"), and its species
CHARACTERS = {
    "openclonk_wipf": ("quadruped", "wipf"), "openclonk_mooq": ("quadruped", "mooq"),
    "openclonk_puka": ("quadruped", "puka"),
    "openclonk_clonk": ("biped", "clonk"), "openclonk_clonk_steampunk": ("biped", "clonk"),
    "assetcoop_rebecca": ("biped", "rebecca"), "assetcoop_sofia": ("biped", "sofia"),
    "assetcoop_peter_panda": ("biped", "peter_panda"), "assetcoop_plain_humanoid": ("biped", "plain_humanoid"),
}
UNMAPPED = {"openclonk_bat": "winged: spread wings, no legs to stand on; no template has wings",
            "openclonk_squid": "tentacles hanging down: no template fits (--template auto is for it)"}
LEGS = {"front": ("shoulder", ("elbow", "wrist", "paw")), "back": ("hip", ("knee", "ankle", "paw"))}


class Skeleton:
    """A rigged character's joints in its file's frame (+y up, +z front, +x left)."""

    def __init__(self, names, parents, positions, weights, vertices):
        self.names = list(names)
        self.parents = np.asarray(parents, dtype=np.int64)
        self.P = np.asarray(positions, dtype=float)
        self.W = np.asarray(weights, dtype=float)
        self.V = np.asarray(vertices, dtype=float)
        self.skin = self.W.sum(axis=0)
        self.weighted = [j for j in range(len(self.names)) if self.skin[j] > 0]
        self.extent = float(np.ptp(self.V, axis=0).max())
        self.ground = float(self.V[:, 1].min())

    def depth(self, j: int) -> int:
        d = 0
        while self.parents[j] >= 0:
            j, d = int(self.parents[j]), d + 1
        return d

    def path(self, j: int) -> list[int]:
        """Root ... j."""
        out = [j]
        while self.parents[out[-1]] >= 0:
            out.append(int(self.parents[out[-1]]))
        return out[::-1]

    def children(self, j: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def subtree_weighted(self, j: int) -> bool:
        stack = [j]
        while stack:
            k = stack.pop()
            if self.skin[k] > 0:
                return True
            stack.extend(self.children(k))
        return False

    def nearest(self, candidates, point) -> int | None:
        """The candidate joint nearest ``point``; ties to the one nearer the root, then the first."""
        if not candidates:
            return None
        d = [float(np.linalg.norm(self.P[j] - point)) for j in candidates]
        best = min(d)
        tied = [j for j, dj in zip(candidates, d) if dj <= best + 1e-6 * self.extent]
        return min(tied, key=lambda j: (self.depth(j), j))

    def skin_centroid(self, j: int) -> np.ndarray:
        w = self.W[:, j]
        return (w[:, None] * self.V).sum(axis=0) / w.sum()


def template_shares(kind: str = "quadruped") -> dict[str, dict[str, float]]:
    """{front/back: {joint: height above the paw's end as a share of the leg's top's}} of a built-in template."""
    joints = {j["name"]: np.array(j["position"], float)
              for j in json.loads((ROOT / "templates" / f"{kind}.json").read_text())["joints"]}
    out = {}
    for end, (top, lower) in LEGS.items():
        g, t = joints[f"{end}_left_paw_end"][1], joints[f"{end}_left_{top}"][1]
        out[end] = {name: float((joints[f"{end}_left_{name}"][1] - g) / (t - g)) for name in lower}
    return out


def assign_in_order(shares: list[float], targets: dict[str, float]) -> list[tuple[int, str]]:
    """[(index into shares, template name)]: joints at heights ``shares`` (top down) matched in order to the
    template joints at ``targets`` (top down) with the least total difference, as many as both have (a leg with
    more joints than the template's leaves the ones that fit worst unnamed)."""
    names = list(targets)
    k = min(len(shares), len(names))
    best, best_cost = [], np.inf
    for joints in itertools.combinations(range(len(shares)), k):
        for chosen in itertools.combinations(range(len(names)), k):
            cost = sum(abs(shares[j] - targets[names[c]]) for j, c in zip(joints, chosen))
            if cost < best_cost - 1e-12:
                best, best_cost = [(j, names[c]) for j, c in zip(joints, chosen)], cost
    return best


def quadruped_map(s: Skeleton) -> dict[str, str | None]:
    mid_width = 0.04 * s.extent
    midline = [j for j in s.weighted if abs(s.P[j, 0]) < mid_width]
    trunk_y = float(np.median(s.P[midline, 1]))
    seeds = [j for j in s.weighted if abs(s.P[j, 0]) >= mid_width and s.P[j, 1] < trunk_y]
    # and the joints off the mid-plane above them in the hierarchy (a hip joint level with the back)
    side = set(seeds)
    for j in seeds:
        k = int(s.parents[j])
        while k >= 0 and abs(s.P[k, 0]) >= mid_width and np.sign(s.P[k, 0]) == np.sign(s.P[j, 0]):
            if s.skin[k] > 0:
                side.add(k)
            k = int(s.parents[k])
    side = sorted(side, key=lambda j: (s.P[j, 2], j))
    z = s.P[side, 2]
    cut = int(np.argmax(np.diff(z))) + 1
    halves = {"back": side[:cut], "front": side[cut:]}
    shares = template_shares()
    out: dict[str, str | None] = {}
    tops = {}
    for end, members in halves.items():
        top_name, lower = LEGS[end]
        for side_name, sign in (("left", 1), ("right", -1)):
            leg = sorted((j for j in members if np.sign(s.P[j, 0]) == sign), key=lambda j: -s.P[j, 1])
            if not leg:
                raise ValueError(f"no {end} {side_name} leg")
            top = leg[0]
            tops.setdefault(end, []).append(top)
            out[f"{end}_{side_name}_{top_name}"] = s.names[top]
            height = s.P[top, 1] - s.ground
            rest = leg[1:]
            for name in lower:
                out[f"{end}_{side_name}_{name}"] = None
            for i, name in assign_in_order([(s.P[j, 1] - s.ground) / height for j in rest], shares[end]):
                out[f"{end}_{side_name}_{name}"] = s.names[rest[i]]
    front_top = s.P[tops["front"]].mean(axis=0)
    back_top = s.P[tops["back"]].mean(axis=0)
    ahead = [j for j in midline if s.skin_centroid(j)[2] > front_top[2]]
    head = max(ahead, key=lambda j: (s.skin[j], -s.depth(j), -j))
    in_head = set(_descendants(s, head))
    behind = [j for j in midline if s.P[j, 2] < back_top[2] - 0.05 * s.extent]
    tail = s.nearest(behind, back_top)
    body = [j for j in midline if j not in in_head and j not in behind]
    hips = s.nearest(body, back_top)
    chest = s.nearest([j for j in body if j != hips and s.P[j, 2] <= front_top[2] + 0.05 * s.extent], front_top)
    between = [j for j in body if j not in (hips, chest) and min(s.P[hips, 2], s.P[chest, 2]) < s.P[j, 2]
               < max(s.P[hips, 2], s.P[chest, 2])]
    spine = s.nearest(between, (s.P[hips] + s.P[chest]) / 2)
    path = s.path(head)
    neck = None
    if chest in path:
        inner = [j for j in path[path.index(chest) + 1:-1] if j not in (hips, spine)]
        neck = inner[-1] if inner else None
    out.update({"hips": s.names[hips], "spine": _name(s, spine), "chest": _name(s, chest),
                "neck": _name(s, neck), "head": s.names[head], "tail_base": _name(s, tail)})
    return dict(sorted(out.items()))


def biped_map(s: Skeleton) -> dict[str, str | None]:
    height = float(np.ptp(s.V[:, 1]))
    mid_width = 0.04 * height
    off = lambda j: abs(s.P[j, 0]) >= mid_width  # noqa: E731
    out: dict[str, str | None] = {}
    feet = {}
    for side_name, sign in (("left", 1), ("right", -1)):
        ours = [j for j in s.weighted if np.sign(s.P[j, 0]) == sign and off(j)]
        foot = min(ours, key=lambda j: (s.P[j, 1], j))
        feet[side_name] = foot
        leg = [j for j in s.path(foot) if off(j)]
        keys = ("hip", "knee", "ankle")
        for k, key in enumerate(keys):
            out[f"{side_name}_{key}"] = s.names[leg[k]] if k < len(leg) else None
        toe = leg[3] if len(leg) > 3 and s.children(leg[3]) else None
        out[f"{side_name}_toe"] = _name(s, toe)
    hip_top = max(s.P[s.names.index(out[f"{sn}_hip"]), 1] for sn in ("left", "right"))
    shoulders = []
    for side_name, sign in (("left", 1), ("right", -1)):
        ours = [j for j in s.weighted if np.sign(s.P[j, 0]) == sign and s.P[j, 1] > hip_top
                and s.subtree_weighted(j)]
        hand = max(ours, key=lambda j: (abs(s.P[j, 0]), -j))
        arm = [j for j in s.path(hand) if off(j)]
        shoulder = arm[0]
        # one bone from the shoulder to the hand (the panda's arm): no elbow or wrist joint
        wrist_at = next((k for k in range(2, len(arm))
                         if sum(s.subtree_weighted(c) for c in s.children(arm[k])) >= 2), len(arm) - 1)
        middle = arm[1:wrist_at]
        lengths = np.r_[0, np.cumsum(np.linalg.norm(np.diff(s.P[arm[:wrist_at + 1]], axis=0), axis=1))]
        elbow = (min(middle, key=lambda j: abs(lengths[arm.index(j)] - lengths[-1] / 2)) if middle else None)
        out.update({f"{side_name}_shoulder": s.names[shoulder], f"{side_name}_elbow": _name(s, elbow),
                    f"{side_name}_wrist": s.names[arm[wrist_at]] if wrist_at > 0 else None})
        shoulders.append(shoulder)
    shoulder_y = float(np.mean(s.P[shoulders, 1]))
    # the trunk's joints lie on the mid-plane (closer than the limbs' 4 %: a breast joint is not the chest)
    structural = [j for j in range(len(s.names)) if abs(s.P[j, 0]) < mid_width / 2 and s.subtree_weighted(j)]
    above = [j for j in structural if s.P[j, 1] > shoulder_y and s.skin[j] > 0]
    head = max(above, key=lambda j: (s.skin[j], -s.depth(j), -j))
    parent = int(s.parents[head])
    neck = parent if parent >= 0 and s.P[parent, 1] > shoulder_y - 0.02 * height else None
    hip_mid = np.mean([s.P[s.names.index(out[f"{sn}_hip"])] for sn in ("left", "right")], axis=0)
    trunk = [j for j in structural if s.skin[j] > 0 and j not in (head, neck)
             and hip_mid[1] - 0.05 * height < s.P[j, 1] < shoulder_y]
    hips = s.nearest(trunk, hip_mid)
    upper = [j for j in trunk if j != hips and s.P[j, 1] > (hip_mid[1] + shoulder_y) / 2]
    chest = max(upper, key=lambda j: (s.P[j, 1], -s.depth(j), -j)) if upper else None
    between = [j for j in trunk if j not in (hips, chest) and s.P[hips, 1] < s.P[j, 1]
               < (s.P[chest, 1] if chest is not None else shoulder_y)]
    spine = s.nearest(between, (s.P[hips] + (s.P[chest] if chest is not None else s.P[hips])) / 2) \
        if chest is not None else None
    out.update({"hips": _name(s, hips), "spine": _name(s, spine), "chest": _name(s, chest),
                "neck": _name(s, neck), "head": s.names[head]})
    return dict(sorted(out.items()))


def _descendants(s: Skeleton, j: int) -> list[int]:
    out, stack = [], [j]
    while stack:
        k = stack.pop()
        out.append(k)
        stack.extend(s.children(k))
    return out


def _name(s: Skeleton, j) -> str | None:
    return None if j is None else s.names[j]


def read(glb: Path) -> Skeleton:
    from autorig.exchange.gltf import read_glb
    rig = read_glb(glb)
    return Skeleton(rig.names, rig.parents, rig.joints, rig.weights, rig.vertices)


def derive(folder: Path) -> dict:
    kind, species = CHARACTERS[folder.name]
    skeleton = read(folder / "model.glb")
    mapping = quadruped_map(skeleton) if kind == "quadruped" else biped_map(skeleton)
    return {"name": folder.name, "source_group": folder.name.split("_", 1)[0], "species": species,
            "category": kind, "model": f"shared/data/more/{folder.name}/model.glb", "up_axis": "+y",
            "front_axis": "+z", f"{kind}_map": mapping,
            "derived": "python data/maps/derive.py (joints named by where they lie; see its docstring)"}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--more", type=Path, default=ROOT.parent / "shared" / "data" / "more")
    parser.add_argument("--out", type=Path, default=ROOT / "data" / "maps")
    parser.add_argument("--check", action="store_true", help="compare with the committed maps, write nothing")
    args = parser.parse_args(argv)
    if not args.more.is_dir():
        print(f"error: no characters at {args.more}", file=sys.stderr)
        return 2
    differ = 0
    for name in sorted(CHARACTERS):
        folder = args.more / name
        if not (folder / "model.glb").is_file():
            print(f"{name}: missing, skipped")
            continue
        text = json.dumps(derive(folder), indent=1) + "\n"
        target = args.out / f"{name}.json"
        if args.check:
            same = target.is_file() and target.read_text() == text
            differ += not same
            print(f"{name}: {'same' if same else 'DIFFERS'}")
            continue
        tmp = target.with_suffix(".json.tmp")
        tmp.write_text(text)
        tmp.replace(target)
        print(f"{name}: {target}")
    for name, why in UNMAPPED.items():
        print(f"{name}: not mapped ({why})")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
