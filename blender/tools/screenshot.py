"""The picture in docs/blender.md, rendered headless:

    blender -b --factory-startup --python blender/tools/screenshot.py -- ZIP OUT.png

installs the add-on from ZIP (into Blender's user folders: set BLENDER_USER_SCRIPTS to a
temporary folder to keep them clean), grows the quaking aspen and renders it."""

import sys

import bpy

zip_path, out = sys.argv[sys.argv.index("--") + 1 :][:2]
bpy.ops.preferences.addon_install(filepath=zip_path)
bpy.ops.preferences.addon_enable(module="sylva_blender")

from sylva_blender import preview  # noqa: E402  (importable once the add-on is enabled)

assert bpy.ops.sylva.grow(preset="wp-quaking-aspen") == {"FINISHED"}
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 4.0
sun.rotation_euler = (0.7, 0.2, 0.5)
bpy.context.scene.collection.objects.link(sun)
preview.render(bpy.context.view_layer.objects.active, out, size=480, samples=32)
print("screenshot:", out)
