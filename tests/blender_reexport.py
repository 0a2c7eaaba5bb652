"""Runs inside Blender: import a .glb and export the scene again with Blender's own glTF exporter, as an artist
who rigged in Blender would hand a rig over (tests/test_blender.py re-weights it with ``--skeleton``).

    blender -b --factory-startup --python tests/blender_reexport.py -- IN.glb OUT.glb
"""
import sys

import bpy
import numpy

if "bool" not in vars(numpy):   # see blender_check.py
    numpy.bool = bool

source, target = sys.argv[sys.argv.index("--") + 1:][:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=source)
bpy.ops.export_scene.gltf(filepath=target, export_format="GLB")
