"""Runs inside Blender: import a .glb as a user would, pose one bone, and report what happened.

    blender -b --factory-startup --python tests/blender_check.py -- RIG.glb BONE [FRAME]

FRAME is a frame of Blender's scene (24 per second) at which to play the file's first animation.

Prints one line ``AUTORIG_BLENDER {json}`` (tests/test_blender.py reads it):

    armatures, meshes      object counts after the import
    bones                  the armature's bone names
    groups                 the skinned mesh's vertex group names
    weighted               {group: number of vertices with weight > 0 in it}
    modifier               whether the mesh has an Armature modifier bound to that armature
    moved_follow           median displacement of vertices weighted >= 0.9 to BONE, after turning BONE 90
                           degrees about its own x axis (Blender's evaluated mesh, world coordinates)
    moved_other            largest displacement of vertices with no weight on BONE or its descendants
    height                 the mesh's extent along Blender's up axis (z)
    actions                {action name: [frame start, frame end, rotation curves, location curves]}
    moved_at_frame         with FRAME: largest vertex displacement at that animation frame from the rest pose
    box_at_frame           with FRAME: the posed mesh's bounding box [[min x, y, z], [max x, y, z]] (Blender's
                           axes: z up, glTF's -z is Blender's y)
"""
import json
import math
import sys

import bpy
import numpy
from mathutils import Quaternion

# Debian's Blender 3.4 glTF importer still spells numpy's bool as np.bool, which numpy 1.24 (Debian's too)
# removed; put the alias back so the importer runs as it did when it shipped.
if "bool" not in vars(numpy):
    numpy.bool = bool


def evaluated(mesh_object) -> list:
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    posed = mesh_object.evaluated_get(depsgraph)
    data = posed.to_mesh()
    points = [posed.matrix_world @ v.co for v in data.vertices]
    posed.to_mesh_clear()
    return points


def main() -> None:
    args = sys.argv[sys.argv.index("--") + 1:]
    path, bone = args[0], args[1]
    frame = int(args[2]) if len(args) > 2 else None
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)

    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    report = {"armatures": len(armatures), "meshes": len(meshes)}
    armature, mesh = armatures[0], meshes[0]
    report["bones"] = [b.name for b in armature.data.bones]
    names = {g.index: g.name for g in mesh.vertex_groups}
    report["groups"] = sorted(names.values())
    weights = [{names[g.group]: g.weight for g in v.groups if g.weight > 0} for v in mesh.data.vertices]
    weighted = {}
    for row in weights:
        for name in row:
            weighted[name] = weighted.get(name, 0) + 1
    report["weighted"] = weighted
    report["modifier"] = any(m.type == "ARMATURE" and m.object == armature for m in mesh.modifiers)
    report["actions"] = {a.name: [a.frame_range[0], a.frame_range[1],
                                  sum(c.data_path.endswith("rotation_quaternion") for c in a.fcurves),
                                  sum(c.data_path.endswith("location") for c in a.fcurves)]
                         for a in bpy.data.actions}

    # Pose in the rest state: the importer may have left an animation playing on the armature.
    if armature.animation_data is not None:
        armature.animation_data.action = None
    for pose_bone in armature.pose.bones:
        pose_bone.rotation_mode = "QUATERNION"
        pose_bone.rotation_quaternion = Quaternion()
        pose_bone.location = (0.0, 0.0, 0.0)
    rest = evaluated(mesh)
    report["height"] = max(p.z for p in rest) - min(p.z for p in rest)

    moving = {bone} | {b.name for b in armature.data.bones[bone].children_recursive}
    armature.pose.bones[bone].rotation_quaternion = Quaternion((1.0, 0.0, 0.0), math.radians(90))
    posed = evaluated(mesh)
    moved = [(a - b).length for a, b in zip(posed, rest)]
    follow = sorted(d for d, row in zip(moved, weights) if row.get(bone, 0) >= 0.9)
    report["moved_follow"] = follow[len(follow) // 2] if follow else None
    report["moved_other"] = max((d for d, row in zip(moved, weights) if not moving & set(row)), default=None)
    armature.pose.bones[bone].rotation_quaternion = Quaternion()

    if frame is not None:
        armature.animation_data.action = bpy.data.actions[0]
        for pose_bone in armature.pose.bones:  # let the action drive every channel it has
            pose_bone.rotation_quaternion = Quaternion()
        bpy.context.scene.frame_set(frame)
        points = evaluated(mesh)
        report["moved_at_frame"] = max((a - b).length for a, b in zip(points, rest))
        report["box_at_frame"] = [[min(p[i] for p in points) for i in range(3)],
                                  [max(p[i] for p in points) for i in range(3)]]
    print("AUTORIG_BLENDER " + json.dumps(report))


main()
