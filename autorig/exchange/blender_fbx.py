"""Runs inside Blender (``autorig.exchange.fbx``): import autorig's .glb and export it as FBX.

    blender -b --factory-startup --python blender_fbx.py -- IN.glb OUT.fbx

The textures are embedded in the FBX (path_mode COPY with embed_textures), so the file stands alone; the
armature's leaf bones are not padded with Blender's extra "_end" bones, the template's tips being joints already.
"""
import os
import sys

import bpy
import numpy

# Debian's Blender 3.4 glTF importer still spells numpy's bool as np.bool, which numpy 1.24 removed.
if "bool" not in vars(numpy):
    numpy.bool = bool

source, target = sys.argv[sys.argv.index("--") + 1:][:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=source)
# The glTF's images come in packed, without a file name; give each one (its bytes as they are) so the FBX
# names a texture file beside the embedded copy.
for image in bpy.data.images:
    if image.packed_file is not None and not image.filepath:
        extension = {"JPEG": ".jpg"}.get(image.file_format, ".png")
        name = os.path.join(os.path.dirname(os.path.abspath(target)), bpy.path.clean_name(image.name) + extension)
        with open(name, "wb") as f:
            f.write(image.packed_file.data)
        image.filepath = name
bpy.ops.export_scene.fbx(filepath=target, object_types={"ARMATURE", "MESH"}, add_leaf_bones=False,
                         path_mode="COPY", embed_textures=True, bake_anim=False)
