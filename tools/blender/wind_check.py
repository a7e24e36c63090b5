# Imports sylva's rigged .glb files into Blender headless and reports the rig and the
# wind clip as an animator would find them (issue 24): the armatures and their bone
# counts, and each action's keyframe range in seconds (frames over the scene's frame rate).
# Usage: blender -b --factory-startup --python tools/blender/wind_check.py -- FILE.glb...
# Prints one line `SYLVA {json}` per file:
#   {"file", "armatures": [{"name", "bones"}], "bones" (over all armatures),
#    "actions": [{"name", "start", "end"}], "start", "end" (over all actions; null
#    without keyframes), "fps"}
# Exits 1 if any import fails. The setup is import_check.py's.
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
        bpy.ops.import_scene.gltf(filepath=path)
        render = bpy.context.scene.render
        fps = render.fps / render.fps_base
        armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
        actions = []
        for action in bpy.data.actions:
            frames = [k.co[0] for fc in action.fcurves for k in fc.keyframe_points]
            if frames:
                actions.append({"name": action.name, "start": min(frames) / fps, "end": max(frames) / fps})
        report = {
            "file": path,
            "armatures": [{"name": o.name, "bones": len(o.data.bones)} for o in armatures],
            "bones": sum(len(o.data.bones) for o in armatures),
            "actions": actions,
            "start": min((a["start"] for a in actions), default=None),
            "end": max((a["end"] for a in actions), default=None),
            "fps": fps,
        }
    except Exception as e:  # noqa: BLE001 - reported, not raised
        failed = True
        report = {"file": path, "error": str(e)}
    print("SYLVA " + json.dumps(report), flush=True)
sys.exit(1 if failed else 0)
