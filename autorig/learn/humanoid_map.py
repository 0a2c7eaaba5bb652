"""The humanoid's joints in a rig that only maps the biped's: read off the rig's own hierarchy.

The corpus's ``joints.json`` files map the biped template (``biped_map``: hips, spine, chest, neck, limbs). The
humanoid (``templates/humanoid.json``) has three spine joints and clavicles instead of one chest: its ``spine``
is the biped's, its ``spine2`` is the biped's chest (where the neck and the arms branch off), and

    spine1           the rig's joint between its spine and its chest (the middle one if there are several:
                     Mixamo's Spine1, Unreal's spine_02, 0 A.D.'s spine1), None when the chest hangs from the
                     spine directly (the glTF samples)
    {side}_clavicle  the parent of the rig's upper arm when that parent is not its chest and hangs below it
                     (Mixamo's LeftShoulder, Unreal's clavicle_l, 0 A.D.'s shoulder_L), None when the arm hangs
                     from the chest itself

so one map per rig serves both templates, and a rig without a joint leaves it to the learner's fill
(``proportions._fill_missing``). A ``humanoid_map`` the file has itself wins.
"""
from __future__ import annotations

KEY = "humanoid_map"


def humanoid_map(biped_map: dict, parent_of: dict[str, str | None]) -> dict[str, str | None]:
    """{humanoid joint name: rig joint name or None} from the rig's ``biped_map`` and ``parent_of`` {rig joint
    name: its parent's name, None for a root}."""
    out = {key: value for key, value in biped_map.items() if key != "chest"}
    spine, chest = biped_map.get("spine"), biped_map.get("chest")
    out["spine2"] = chest
    out["spine1"] = None
    above_chest = list(_ancestors(chest, parent_of)) if chest is not None else []
    if spine in above_chest and above_chest.index(spine) > 0:
        between = above_chest[:above_chest.index(spine)][::-1]     # from the spine up
        out["spine1"] = between[(len(between) - 1) // 2]
    for side in ("left", "right"):
        arm = biped_map.get(f"{side}_shoulder")
        parent = parent_of.get(arm) if arm is not None else None
        out[f"{side}_clavicle"] = parent if parent is not None and parent != chest and chest in _ancestors(
            parent, parent_of) else None
    return out


def with_humanoid_map(meta: dict, joints: list[dict]) -> dict:
    """``meta`` (a corpus joints.json without its joints) with a ``humanoid_map`` derived from its ``biped_map``
    and ``joints`` [{"name", "parent"}] unless it has one or maps no biped."""
    if KEY in meta or not isinstance(meta.get("biped_map"), dict):
        return meta
    parent_of = {j["name"]: j["parent"] for j in joints}
    return {**meta, KEY: humanoid_map(meta["biped_map"], parent_of)}


def _ancestors(joint: str, parent_of: dict):
    """The joints above ``joint`` in the hierarchy, its parent first (a cycle ends the walk)."""
    node, seen = parent_of.get(joint), set()
    while node is not None and node not in seen:
        yield node
        seen.add(node)
        node = parent_of.get(node)
