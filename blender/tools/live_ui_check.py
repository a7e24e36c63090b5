"""Live mode through Blender's own event loop (the test drives ``live.pump`` headless
instead): run Blender's UI, here under Xvfb,

    xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup \
        --python blender/tools/live_ui_check.py -- ZIP OUT.json

installs the add-on from ZIP (into Blender's user folders: set BLENDER_USER_SCRIPTS and
BLENDER_USER_CONFIG to temporary folders to keep them clean), grows the aspen with two
LOD levels and wind, switches Live on and, from a timer, changes a leaf setting and
waits for the leaf mesh to change: ``bpy.app.timers`` runs the live work, as in a
user's session. It records the seconds to the mesh replaced, ``live.stats()``, the gaps
between 10 ms heartbeat timers (how often the event loop ran) while idle, in the second
after moving the tree (a redraw without sylva) and during the regrow, and the status a
bad value shows; then quits."""

import json
import sys
import time

import bpy
import numpy as np

zip_path, out_path = sys.argv[sys.argv.index("--") + 1 :][:2]
bpy.ops.preferences.addon_install(filepath=zip_path)
bpy.ops.preferences.addon_enable(module="sylva_blender")

from sylva_blender import live  # noqa: E402  (importable once the add-on is enabled)

result = {}
state = {"step": "grow", "last": None, "gaps": []}


def coords(obj):
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co


def heartbeat():
    now = time.perf_counter()
    if state["last"] is not None:
        state["gaps"].append(now - state["last"])
    state["last"] = now
    return 0.01


def listen():
    state["gaps"], state["last"] = [], None
    bpy.app.timers.register(heartbeat)


def gaps():
    bpy.app.timers.unregister(heartbeat)
    g = sorted(state["gaps"])
    return {
        "ticks": len(g),
        "max_s": g[-1] if g else None,
        "median_s": g[len(g) // 2] if g else None,
    }


def driver():
    props = bpy.context.scene.sylva
    step = state["step"]
    if step == "grow":
        settings = "lod.levels = [20000, 5000]\nwind.preset = 'breeze'"
        assert bpy.ops.sylva.grow(preset="wp-quaking-aspen", settings=settings) == {"FINISHED"}
        state["root"] = bpy.context.view_layer.objects.active.name
        props.live = True
        state["step"] = "listen"
        return 3.0  # the session warms up meanwhile
    if step == "listen":  # one idle second: how often the event loop runs
        listen()
        state["step"] = "idle"
        return 1.0
    root = bpy.data.objects[state["root"]]
    leaf = next(o for o in root.children if o.get("sylva_lod") == 0 and "leaf" in o.name)
    if step == "idle":
        result["idle_gaps"] = gaps()
        listen()  # a change Blender redraws the viewport for, without sylva: a move
        root.location.x += 1.0
        state["step"] = "moved"
        return 1.0
    if step == "moved":
        result["move_gaps"] = gaps()
        state["before"], state["t0"] = coords(leaf), time.perf_counter()
        listen()
        props.leaves__shape = "lanceolate"
        state["step"] = "wait"
        return 0.02
    if step == "wait":
        after = coords(leaf)
        changed = len(after) != len(state["before"]) or bool((after != state["before"]).any())
        if not changed and time.perf_counter() - state["t0"] < 10.0:
            return 0.02
        result["leaf_change_s"] = time.perf_counter() - state["t0"]
        result["changed"] = changed
        result["regrow_gaps"] = gaps()
        result["stats"] = live.stats()
        result["status"] = props.live_status
        props.settings = "mesh.sides = 1"
        state["step"] = "error"
        return 1.5
    result["error_status"] = props.live_status
    props.live = False
    with open(out_path, "w") as f:
        json.dump(result, f, indent=1)
    print("live_ui_check:", json.dumps(result))
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(driver, first_interval=1.0)
