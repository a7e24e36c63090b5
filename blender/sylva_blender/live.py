"""Live mode (issue 43, item 4). With the panel's **Live** on, every change of a panel
setting (preset, seed, settings text, any schema setting) regrows the live tree —
the sylva tree that was active when Live was switched on, or a new one grown then —
``DEBOUNCE_S`` after the last change.

The grow runs in one worker thread through one ``sylva.Session`` per tree object, so
only the pipeline stages a change touches run again (a leaf change keeps the skeleton
and the bark; docs/python.md), and ``Session.update`` releases the GIL, so Blender's UI
stays responsive. The worker also makes everything the build needs that is not Blender
data (``build.Prepared``: the arrays, the glTF, the image hashes). Blender data is
touched only on the main thread: ``pump`` starts the regrow whose debounce ran out and
builds a finished result in place (``build.build(..., root=tree)``: same objects,
transform, selection and modifiers), once Blender is in Object Mode. Only the latest
recipe's result is built: a result that a newer change made stale is dropped. A bad
setting, or a grow that fails, is an error in the panel's status line (and on the
console), and the tree stays as it was.

In the UI a ``bpy.app.timers`` function calls ``pump``. Headless (``blender -b``)
timers do not run while a script does; the script calls ``pump(timeout)`` itself."""

import threading
import time
import uuid

import bpy

from . import build, settings

DEBOUNCE_S = 0.3
TICK_S = 0.05


class _State:
    """The live work: a pending change, the worker's next job and its result."""

    def __init__(self):
        self.cond = threading.Condition()
        self.sylva = None
        self.due = None  # time.monotonic() at which the pending change is regrown
        self.changed_at = None  # when the last change came
        self.scene = None  # name of the scene whose panel changed
        self.job = None  # the worker's next job
        self.running = None  # the job the worker runs
        self.result = None  # (job, build.Prepared or an error message, timings)
        self.generation = 0  # the latest job's
        self.epoch = 0  # bumped when Live goes off: older jobs keep no session
        self.sessions = {}  # tree object name -> (origin, sylva.Session)
        self.thread = None
        self.stop = False
        self.dropped = 0  # stale results not built
        self.last = {}  # what the last regrow built measured


_s = _State()


def stats():
    """What the last live regrow measured: ``latency_s`` (last change to the tree
    replaced), ``grow_s`` (the worker: session update and ``Prepared``), ``build_s``
    (the in-place build), ``stages`` (those the session ran), and ``dropped`` (stale
    results not built so far)."""
    return dict(_s.last, dropped=_s.dropped)


def _status(props, text):
    if props.live_status == text:
        return
    props.live_status = text
    if text.startswith("error"):
        print(f"sylva live: {text}")
    for window in getattr(bpy.context.window_manager, "windows", []):
        for area in window.screen.areas if window.screen else ():
            if area.type == "VIEW_3D":  # the sidebar only: a new mesh redraws the view
                for region in area.regions:
                    if region.type == "UI":
                        region.tag_redraw()


def _ensure_timer():
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=TICK_S)


def _tick():
    try:
        idle = pump(0.0)
    except Exception as e:  # a timer never lets a traceback reach the console
        print(f"sylva live: error: {e!r}")
        idle = True
    return None if idle else TICK_S


def _worker():
    """The worker thread: runs one job at a time, the latest given."""
    while True:
        with _s.cond:
            while _s.job is None and not _s.stop:
                _s.cond.wait()
            if _s.stop:
                return
            job, _s.job = _s.job, None
            _s.running = job
            entry = _s.sessions.get(job["tree"])
        t0 = time.perf_counter()
        out, stages = None, []
        try:
            if entry is None or entry[0] != job["origin"]:
                session = _s.sylva.Session(job["recipe"])
                tree = session.run()
                entry = (job["origin"], session)
            else:
                tree = entry[1].update(job["recipe"])
            stages = list(entry[1].last_run)
            if not job["warm"]:
                out = build.Prepared(tree)
        except _s.sylva.SylvaError as e:
            out = f"error: {e}"
        except Exception as e:  # a bug: reported in the panel, not raised in a thread
            out = f"error: {e!r}"
        seconds = time.perf_counter() - t0
        with _s.cond:
            if not isinstance(out, str) and job["epoch"] == _s.epoch:
                _s.sessions[job["tree"]] = entry
            _s.running = None
            if job["warm"]:
                pass
            elif job["generation"] == _s.generation:
                _s.result = (job, out, seconds, stages)
            else:
                _s.dropped += 1
            _s.cond.notify_all()


def _submit(job):
    with _s.cond:
        job["epoch"] = _s.epoch
        if not job["warm"]:
            _s.generation += 1
            job["generation"] = _s.generation
        if _s.job is not None and not _s.job["warm"]:
            _s.dropped += 1  # a queued job that never ran
        _s.job = job
        if _s.thread is None or not _s.thread.is_alive():
            _s.stop = False
            _s.thread = threading.Thread(target=_worker, name="sylva-live", daemon=True)
            _s.thread.start()
        _s.cond.notify_all()
    _ensure_timer()


def _origin(props):
    return props.base or f"preset:{props.preset}"


LIVE_ID = "sylva_live_id"


def _mark_live(props, root):
    """Makes ``root`` the live tree, tagged so that it is found again if renamed."""
    props.live_tree = root.name
    root[LIVE_ID] = uuid.uuid4().hex
    props.live_id = root[LIVE_ID]


def _live_root(props):
    """The live tree: by name, else (renamed) by its tag; None when it is gone."""
    if not props.live_tree:
        return None
    root = bpy.data.objects.get(props.live_tree)
    if root is not None and build.RECIPE_PROP in root and root.get(LIVE_ID) == props.live_id:
        return root
    for obj in bpy.data.objects:
        if obj.get(LIVE_ID) == props.live_id and build.RECIPE_PROP in obj:
            with _s.cond:  # its session goes with the new name
                entry = _s.sessions.pop(props.live_tree, None)
                if entry is not None:
                    _s.sessions[obj.name] = entry
            props.live_tree = obj.name
            return obj
    return None


def changed(context):
    """A panel setting changed: with Live on, (re)starts the debounce."""
    props = context.scene.sylva
    if not props.live:
        return
    _s.changed_at = time.monotonic()
    _s.due = _s.changed_at + DEBOUNCE_S
    _s.scene = context.scene.name
    _ensure_timer()


def toggled(props, context):
    """The Live toggle's update callback. On: the active sylva tree becomes the live
    tree and the panel shows its stored recipe (a session is warmed up with it in the
    background); with no sylva tree active, a tree is grown from the panel at once. Off:
    pending work is dropped and the sessions are freed."""
    from . import ui

    if not props.live:
        with _s.cond:
            _s.job = None
            _s.generation += 1  # a result still running is dropped
            _s.epoch += 1  # ... and keeps no session
            _s.sessions.clear()
        _s.due = None
        props.live_tree = ""
        _status(props, "")
        return
    root = build.tree_root(context.view_layer.objects.active)
    if root is None:
        props.live_tree = ""
        _s.changed_at = time.monotonic()
        _s.due = _s.changed_at  # grow one now
        _s.scene = context.scene.name
        _status(props, "Live: growing a new tree")
        _ensure_timer()
        return
    _mark_live(props, root)
    sylva = _s.sylva
    try:
        recipe = sylva.Recipe.from_toml(root[build.RECIPE_PROP])
    except sylva.SylvaError as e:
        _status(props, f"error: the recipe stored on {root.name}: {e}")
        return
    if recipe.name in sylva.presets():
        ui._state["loading"] += 1
        try:
            props.preset = recipe.name
        finally:
            ui._state["loading"] -= 1
    ui.show_recipe(props, recipe, base=root[build.RECIPE_PROP])
    recipe.seed = int(root.get(build.SEED_PROP, recipe.seed))
    _submit({"tree": root.name, "origin": _origin(props), "recipe": recipe, "warm": True})
    _status(props, f"Live: {root.name}")


def _start(props):
    """The debounce ran out: the panel's recipe goes to the worker."""
    from . import ui

    sylva = _s.sylva
    root = _live_root(props)
    if props.live_tree and root is None:
        _status(props, f"error: the live tree {props.live_tree} is gone; switch Live off and on")
        return
    try:
        recipe = ui.panel_recipe(props)
        if props.seed >= 0:
            recipe.seed = props.seed
        elif root is not None:
            recipe.seed = int(root.get(build.SEED_PROP, recipe.seed))
    except (sylva.SylvaError, settings.SettingsError) as e:
        _status(props, f"error: {e} (the tree is unchanged)")
        return
    tree = root.name if root is not None else ""
    _submit(
        {
            "tree": tree,
            "origin": _origin(props),
            "recipe": recipe,
            "warm": False,
            "changed_at": _s.changed_at,
        }
    )


def _window_override():
    """A context with a window for building from a timer (edit mode needs one)."""
    wm = bpy.context.window_manager
    if bpy.context.window is None and wm is not None and wm.windows:
        return bpy.context.temp_override(window=wm.windows[0])
    return _Nothing()


class _Nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _finish(props, job, out, seconds, stages):
    """Builds a finished result in place (main thread), unless a newer change made it
    stale."""
    if job["generation"] != _s.generation or _s.due is not None:
        _s.dropped += 1
        return
    if isinstance(out, str):
        _status(props, f"{out} (the tree is unchanged)")
        return
    root = _live_root(props)
    if props.live_tree and root is None:
        _status(props, f"error: the live tree {props.live_tree} is gone; switch Live off and on")
        return
    t0 = time.perf_counter()
    try:
        with _window_override():
            context = bpy.context
            new = root is None
            root = build.build(out, context, root=root)
            if new:
                for obj in context.view_layer.objects:
                    obj.select_set(False)
                root.select_set(True)
                context.view_layer.objects.active = root
    except Exception as e:  # a Blender error while building: a status, not a traceback
        _status(props, f"error: building the tree in Blender failed: {e!r}")
        return
    if job["tree"] != root.name:  # a new tree: its session goes with it
        with _s.cond:
            entry = _s.sessions.pop(job["tree"], None)
            if entry is not None:
                _s.sessions[root.name] = entry
        _mark_live(props, root)
    build_s = time.perf_counter() - t0
    latency = time.monotonic() - job["changed_at"]
    _s.last = {
        "latency_s": latency,
        "grow_s": seconds,
        "build_s": build_s,
        "stages": stages,
        "triangles": out.triangles,
    }
    _status(
        props,
        f"Live: {root.name}, {out.triangles} triangles, {latency:.2f} s after the change",
    )


def running():
    """Whether the worker is growing a tree now."""
    with _s.cond:
        return _s.running is not None


def idle():
    """Whether no live work is pending (no change waiting, no job, no result)."""
    with _s.cond:
        busy = _s.job is not None or _s.running is not None or _s.result is not None
    return _s.due is None and not busy


def pump(timeout=0.0):
    """Does the live work that is due — sends the panel's recipe to the worker once the
    debounce ran out, builds a finished result — and waits up to ``timeout`` seconds
    for the rest. Main thread only. Returns True when no work is left."""
    deadline = time.monotonic() + timeout
    while True:
        scene = bpy.data.scenes.get(_s.scene) if _s.scene else bpy.context.scene
        props = scene.sylva if scene is not None else None
        if _s.due is not None and time.monotonic() >= _s.due:
            _s.due = None
            if props is not None and props.live:
                _start(props)
        with _s.cond:
            result, _s.result = _s.result, None
        if result is not None and props is not None and props.live:
            if bpy.context.mode != "OBJECT":  # mesh data is not replaced in Edit Mode
                with _s.cond:
                    if _s.result is None:
                        _s.result = result
                _status(props, "Live: the regrown tree waits for Object Mode")
            else:
                _finish(props, *result)
        if idle():
            return True
        now = time.monotonic()
        if now >= deadline:
            return False
        time.sleep(min(0.005, deadline - now))


def register(sylva):
    """Remembers the ``sylva`` module (the add-on's ``register``)."""
    _s.sylva = sylva


def unregister():
    """Stops the timer and the worker and forgets the sessions."""
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    with _s.cond:
        _s.stop = True
        _s.job = None
        _s.result = None
        _s.generation += 1
        _s.epoch += 1
        _s.sessions.clear()
        _s.cond.notify_all()
    thread = _s.thread
    if thread is not None:
        thread.join(timeout=30.0)
    _s.thread = None
    _s.due = None
