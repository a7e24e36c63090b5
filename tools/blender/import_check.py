# Imports sylva's files into Blender headless and reports what an artist would see
# (issue 23): mesh objects, images the materials use, and smooth shading.
# Usage: blender -b --factory-startup --python tools/blender/import_check.py -- FILE...
# Prints one line `SYLVA {json}` per file; exits 1 if any import fails.
import json
import sys

import numpy

if not hasattr(numpy, "bool"):
    numpy.bool = bool  # Blender 3.4's glTF importer on Debian bookworm's numpy

import bpy

files = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
failed = False
for path in files:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        if path.endswith((".glb", ".gltf")):
            bpy.ops.import_scene.gltf(filepath=path)
        elif path.endswith(".obj"):
            if hasattr(bpy.ops.wm, "obj_import"):
                bpy.ops.wm.obj_import(filepath=path)
            else:
                bpy.ops.import_scene.obj(filepath=path)
        else:
            raise ValueError("unknown extension")
        meshes = [o for o in bpy.data.objects if o.type == "MESH"]
        polys = sum(len(o.data.polygons) for o in meshes)
        smooth = sum(sum(1 for p in o.data.polygons if p.use_smooth) for o in meshes)
        images = []
        for m in bpy.data.materials:
            if not m.use_nodes:
                continue
            for n in m.node_tree.nodes:
                if n.type == "TEX_IMAGE" and n.image is not None:
                    images.append({"material": m.name, "image": n.image.name, "size": list(n.image.size)})
        report = {
            "file": path,
            "objects": sorted(o.name for o in meshes),
            "smooth_share": {
                o.name: sum(1 for p in o.data.polygons if p.use_smooth) / max(1, len(o.data.polygons))
                for o in meshes
            },
            "polygons": polys,
            "smooth": smooth,
            "images": images,
        }
    except Exception as e:  # noqa: BLE001 - reported, not raised
        failed = True
        report = {"file": path, "error": str(e)}
    print("SYLVA " + json.dumps(report), flush=True)
sys.exit(1 if failed else 0)
