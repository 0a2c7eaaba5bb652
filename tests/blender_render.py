"""Runs inside Blender: import a rigged .glb or .fbx as a user would, and render a picture of it.

    blender -b --factory-startup --python tests/blender_render.py -- RIG.glb|RIG.fbx OUT.png [BONE]

With BONE, that bone is turned 50 degrees about its own x axis first, so the picture shows the skin following.

Prints one line ``AUTORIG_BLENDER {json}`` (tests/test_blender.py reads it):

    armatures, meshes   object counts after the import
    bones               the armature's bone names
    groups              vertex group names over all meshes
    textures            {material name: [image name, width, height]} for every image node that feeds the
                        Principled BSDF's Base Color (through any nodes in between)
    saturation          mean colour saturation (HSV) of the picture's pixels that show the mesh
    covered             fraction of the picture's pixels that show the mesh

The picture: Cycles on the CPU (headless Blender has no GPU context for Eevee), the camera in front of the
mesh's bounding box looking at its centre, one sun and a grey world.
"""
import colorsys
import json
import math
import sys

import bpy
import numpy
from mathutils import Vector

if "bool" not in vars(numpy):   # see blender_check.py
    numpy.bool = bool


def base_color_images(material) -> list:
    """Images whose node feeds the Principled BSDF's Base Color input, directly or through other nodes."""
    if not material.use_nodes:
        return []
    found, seen = [], set()
    for node in material.node_tree.nodes:
        if node.type == "BSDF_PRINCIPLED":
            stack = [link.from_node for link in node.inputs["Base Color"].links]
            while stack:
                source = stack.pop()
                if source.name in seen:
                    continue
                seen.add(source.name)
                if source.type == "TEX_IMAGE" and source.image is not None:
                    found.append(source.image)
                stack.extend(link.from_node for socket in source.inputs for link in socket.links)
    return found


def main() -> None:
    args = sys.argv[sys.argv.index("--") + 1:]
    path, picture, bone = args[0], args[1], (args[2] if len(args) > 2 else None)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.lower().endswith(".fbx"):
        bpy.ops.import_scene.fbx(filepath=path)
    else:
        bpy.ops.import_scene.gltf(filepath=path)
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    report = {"armatures": len(armatures), "meshes": len(meshes),
              "bones": [b.name for a in armatures for b in a.data.bones],
              "groups": sorted({g.name for m in meshes for g in m.vertex_groups}), "textures": {}}
    for mesh in meshes:
        for slot in mesh.material_slots:
            if slot.material is not None:
                report["textures"][slot.material.name] = [[i.name, i.size[0], i.size[1]]
                                                          for i in base_color_images(slot.material)]

    if bone is not None:
        pose_bone = armatures[0].pose.bones[bone]
        pose_bone.rotation_mode = "XYZ"
        pose_bone.rotation_euler = (math.radians(50), 0, 0)
        bpy.context.view_layer.update()
    corners = [m.matrix_world @ Vector(c) for m in meshes for c in m.bound_box]
    low = Vector([min(c[i] for c in corners) for i in range(3)])
    high = Vector([max(c[i] for c in corners) for i in range(3)])
    centre, size = (low + high) / 2, max(high - low)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    # From the front-left and a little above: Blender's front is -y (glTF's +z), up is +z.
    camera.location = centre + Vector((0.7, -1.6, 0.45)) * size
    camera.rotation_euler = (centre - camera.location).to_track_quat("-Z", "Y").to_euler()
    camera.data.lens = 50
    scene.camera = camera
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 4.0
    sun.rotation_euler = (math.radians(50), 0, math.radians(30))
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new("world")
    scene.world.color = (0.35, 0.35, 0.35)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False   # Debian builds Blender without OpenImageDenoise
    scene.render.resolution_x = scene.render.resolution_y = 480
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = picture
    bpy.ops.render.render(write_still=True)

    image = bpy.data.images.load(picture)
    pixels = numpy.array(image.pixels[:]).reshape(-1, 4)
    shown = pixels[pixels[:, 3] > 0.5]
    report["covered"] = len(shown) / len(pixels)
    report["saturation"] = float(numpy.mean([colorsys.rgb_to_hsv(*p[:3])[1] for p in shown[::7]])) if len(shown) else 0
    print("AUTORIG_BLENDER " + json.dumps(report))


main()
