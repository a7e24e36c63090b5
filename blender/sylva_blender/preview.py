"""A headless picture of a built tree: Cycles on the CPU (no GPU or display needed; no
denoiser, which Debian's Blender lacks), transparent film, the scene's camera fitted to
the tree's LOD0 meshes. Used by the test and for the picture in docs/blender.md."""

import bpy
import mathutils
import numpy as np


def render(root, path, size=128, samples=4):
    """Renders the tree of ``root`` alone (every other object hidden from the render)
    with Cycles on the CPU, the scene's camera fitted to its LOD0 meshes, to the PNG
    ``path``; returns the pixels as (size * size, 4) floats, bottom row first."""
    scene = bpy.context.scene
    shown = [o for o in root.children if o.type == "MESH" and o["sylva_lod"] == 0]
    for obj in scene.objects:
        if obj.type in ("MESH", "EMPTY", "ARMATURE"):
            obj.hide_render = obj not in shown
    pts = []
    for obj in shown:
        co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
        obj.data.vertices.foreach_get("co", co)
        pts.append(co.reshape(-1, 3) + np.array(obj.matrix_world.translation))
    pts = np.concatenate(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, radius = mathutils.Vector((lo + hi) / 2), float(np.linalg.norm(hi - lo)) / 2
    cam = scene.camera
    view = mathutils.Vector((0.0, -1.0, 0.25)).normalized()
    cam.location = centre + view * radius * 2.6
    cam.rotation_euler = (-view).to_track_quat("-Z", "Y").to_euler()
    cam.data.clip_end = radius * 10
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.empty(size * size * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)
