"""Runs inside Blender: Blender's own automatic weights ("Parent with Automatic Weights") for a mesh and a joint
skeleton, as an artist would get them. benchmarks/skeleton_weights.py runs it and scores the result.

    blender -b --factory-startup --python benchmarks/blender_auto_weights.py -- MESH.obj JOINTS.json OUT.json
        [--gt-deform]

The OBJ goes through Blender's OBJ importer with its axes left as they are (forward y, up z), so positions keep
the file's coordinates and vertices are matched back to the file's by position. One bone per joint: head at
the joint, tail at its child (of several children, the one that best continues the bone into this joint; at a
root, the one with the largest subtree), a leaf's tail half its incoming bone further on, and a bone that would
have no length (a joint at its child's position, a lone root) gets 5% of the skeleton's extent along +z, since
Blender deletes zero-length bones. Every bone deforms (Blender's default); ``--gt-deform`` instead turns off
deform for the joints that joints.json marks ``"weighted": false`` (information autorig is not given).

Writes {"weights": [V][J] in joints.json's order and the OBJ's vertex order, "unweighted": vertices with no
weight at all, "matched": vertices matched by position, "seconds": time of the parenting}.
"""
import json
import sys
import time

import bpy
import numpy as np
from mathutils import Vector
from mathutils.kdtree import KDTree


def read_obj_vertices(path):
    """[V, 3] the file's vertex positions, in file order."""
    with open(path) as fh:
        return np.array([[float(x) for x in line.split()[1:4]] for line in fh if line.startswith("v ")])


def bone_tails(positions, parents):
    """[J, 3] the tail of each joint's bone (see the module docstring)."""
    J = len(parents)
    children = [[c for c in range(J) if parents[c] == j] for j in range(J)]
    size = [1] * J
    for j in reversed(range(J)):
        if parents[j] >= 0:
            size[parents[j]] += size[j]
    extent = float(np.ptp(positions, axis=0).max()) or 1.0
    tails = np.empty_like(positions)
    for j in range(J):
        head = positions[j]
        incoming = head - positions[parents[j]] if parents[j] >= 0 else None
        if children[j]:
            if incoming is not None and np.linalg.norm(incoming) > 0:
                def along(c):
                    d = positions[c] - head
                    return float(d @ incoming) / (np.linalg.norm(d) * np.linalg.norm(incoming) + 1e-30)
                tails[j] = positions[max(children[j], key=along)]
            else:
                tails[j] = positions[max(children[j], key=lambda c: size[c])]
        else:
            tails[j] = head + 0.5 * incoming if incoming is not None else head
        if np.linalg.norm(tails[j] - head) < 1e-4 * extent:
            tails[j] = head + np.array([0.0, 0.0, 0.05 * extent])
    return tails


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    mesh_path, joints_path, out_path = args[:3]
    gt_deform = "--gt-deform" in args
    with open(joints_path) as fh:
        joints = json.load(fh)["joints"]
    names = [j["name"] for j in joints]
    index = {n: i for i, n in enumerate(names)}
    parents = [index[j["parent"]] if j["parent"] is not None else -1 for j in joints]
    positions = np.array([j["position"] for j in joints], float)
    tails = bone_tails(positions, parents)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=mesh_path, forward_axis="Y", up_axis="Z")
    mesh = next(o for o in bpy.data.objects if o.type == "MESH")

    armature_data = bpy.data.armatures.new("skeleton")
    armature = bpy.data.objects.new("skeleton", armature_data)
    bpy.context.scene.collection.objects.link(armature)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="EDIT")
    bones = []
    for j, name in enumerate(names):
        bone = armature_data.edit_bones.new(name)
        bone.head, bone.tail = Vector(positions[j]), Vector(tails[j])
        bone.use_deform = not (gt_deform and joints[j].get("weighted", True) is False)
        bones.append(bone)
    for j, p in enumerate(parents):
        if p >= 0:
            bones[j].parent = bones[p]
    bpy.ops.object.mode_set(mode="OBJECT")

    bpy.ops.object.select_all(action="DESELECT")
    mesh.select_set(True)
    armature.select_set(True)
    bpy.context.view_layer.objects.active = armature
    start = time.perf_counter()
    bpy.ops.object.parent_set(type="ARMATURE_AUTO")
    seconds = time.perf_counter() - start

    group_column = {g.index: index[g.name] for g in mesh.vertex_groups if g.name in index}
    theirs = np.zeros((len(mesh.data.vertices), len(names)))
    for v in mesh.data.vertices:
        for g in v.groups:
            if g.group in group_column:
                theirs[v.index, group_column[g.group]] += g.weight
    tree = KDTree(len(mesh.data.vertices))
    for v in mesh.data.vertices:
        tree.insert(mesh.matrix_world @ v.co, v.index)
    tree.balance()
    ours = read_obj_vertices(mesh_path)
    extent = float(np.ptp(ours, axis=0).max()) or 1.0
    found = [tree.find(Vector(p)) for p in ours]
    matched = sum(dist <= 1e-5 * extent for _, _, dist in found)
    weights = theirs[[i for _, i, _ in found]]
    total = weights.sum(axis=1, keepdims=True)
    weights = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)
    with open(out_path, "w") as fh:
        json.dump({"weights": weights.tolist(), "unweighted": int((total[:, 0] <= 0).sum()), "matched": matched,
                   "seconds": seconds}, fh)


main()
