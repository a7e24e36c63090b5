"""The operators (``sylva.grow``, ``sylva.regrow``, ``sylva.export``), the scene
settings generated from the recipe schema (``sylva.schema()``: the generator's own
settings, one set per generator type, and the mesh, leaves, wind and lod sections; no
hand-written list of keys), the Live toggle (``live.py``) and the sidebar panel (View3D >
Sidebar > sylva)."""

import json

import bpy
import numpy as np
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)
from bpy_extras.io_utils import ExportHelper

from . import build, live, settings

SECTIONS = ("generator", "mesh", "leaves", "wind", "lod")
INT32 = 2**31 - 1

_state = {"sylva": None, "entries": [], "settings_class": None, "loading": 0}


def _attr(entry):
    """The property name of a schema entry: ``mesh__sides`` for ``mesh.sides``;
    ``gen_weber_penn__levels`` for the weber-penn generator's ``generator.levels`` (the
    generators share key names with different kinds and ranges)."""
    key = entry["key"]
    if entry["section"] == "generator":
        gen = entry["generator"].replace("-", "_")
        return f"gen_{gen}__{key.split('.', 1)[1].replace('.', '__')}"
    return key.replace(".", "__")


def _in_panel(entry):
    """Whether the panel shows a schema entry: the SECTIONS, less the generator's type
    (the preset's) and its model files."""
    if entry["section"] not in SECTIONS:
        return False
    return entry["section"] != "generator" or (
        entry["key"] != "generator.type" and entry["kind"]["type"] != "path"
    )


def _changed(self, context):
    """Every panel setting's update callback: schedules a live regrow (live.py)."""
    if not _state["loading"]:
        live.changed(context)


def _schema_property(entry):
    """A Blender property for one schema entry (a string holding JSON for lists and
    integers beyond 32 bits)."""
    kind, default, doc = entry["kind"], entry["default"], entry["doc"] or ""
    name = entry["key"].split(".", 1)[1]
    t = kind["type"]
    up = {"update": _changed}
    if t == "bool":
        return BoolProperty(name=name, description=doc, default=bool(default), **up)
    if t == "mode":
        items = [(v, v, "") for v in kind["values"]]
        first = default if default in kind["values"] else kind["values"][0]
        return EnumProperty(name=name, description=doc, items=items, default=first, **up)
    lo, hi = kind.get("min"), kind.get("max")
    if t == "integer" and all(v is None or abs(v) <= INT32 for v in (lo, hi, default)):
        lo = -INT32 if lo is None else lo
        hi = INT32 if hi is None else hi
        value = default if default is not None else max(lo, 0)
        return IntProperty(name=name, description=doc, min=lo, max=hi, default=value, **up)
    if t == "float":
        kw = {}
        if lo is not None:
            kw["min"] = lo
        if hi is not None:
            kw["max"] = hi
        value = float(default) if default is not None else float(lo or 0.0)
        return FloatProperty(name=name, description=doc, default=value, **kw, **up)
    if t == "string":
        return StringProperty(name=name, description=doc, default=default or "", **up)
    text = "" if default is None else json.dumps(default)
    return StringProperty(name=name, description=f"{doc} (JSON)", default=text, **up)


def _to_recipe(entry, value):
    if isinstance(value, str) and entry["kind"]["type"] not in ("mode", "string"):
        return json.loads(value) if value.strip() else None
    return value


def show_recipe(props, recipe, base=""):
    """Shows ``recipe``'s values in the panel and remembers them, so that a Grow (or a
    live regrow) sets only what was changed since; ``base`` is the recipe's TOML when it
    is not the preset's (a live tree's stored recipe). No live regrow is scheduled."""
    _state["loading"] += 1
    try:
        gen = recipe.get("generator.type") or ""
        props.generator = gen
        props.base = base
        shown = {}
        for entry in _state["entries"]:
            attr = _attr(entry)
            default = props.bl_rna.properties[attr].default
            if entry.get("generator") not in (None, gen):
                value = None
            else:
                value = recipe.get(entry["key"])
            if value is None:  # unset in the recipe: the property's own default
                value = default
            elif isinstance(getattr(props, attr), str) and entry["kind"]["type"] not in (
                "mode",
                "string",
            ):
                value = json.dumps(value)
            try:
                setattr(props, attr, value)
            except (TypeError, ValueError, OverflowError):
                pass  # a value the property cannot show: left as it was
            shown[attr] = getattr(props, attr)
        props.shown = json.dumps(shown)
    finally:
        _state["loading"] -= 1


def _load_preset(self, context):
    """Shows the preset's values in the panel (and, with Live on, regrows the live tree
    as that preset)."""
    if _state["loading"]:
        return
    show_recipe(self, _state["sylva"].Recipe.preset(self.preset))
    live.changed(context)


def panel_changes(props):
    """``[(key, value, where)]`` for every panel setting changed since the recipe shown
    was loaded (or from its default, before any was); only the shown generator's."""
    shown = json.loads(props.shown) if props.shown else {}
    out = []
    for entry in _state["entries"]:
        if entry.get("generator") not in (None, props.generator):
            continue
        attr = _attr(entry)
        value = getattr(props, attr)
        base = shown.get(attr, props.bl_rna.properties[attr].default)
        if isinstance(value, float) and isinstance(base, float):
            same = abs(value - base) <= 1e-6 * max(1.0, abs(base))
        else:
            same = value == base
        if not same:
            if isinstance(value, float):  # a float32 property: its shortest decimal
                value = float(str(np.float32(value)))
            try:
                out.append((entry["key"], _to_recipe(entry, value), f"panel `{entry['key']}`"))
            except ValueError as e:
                raise settings.SettingsError(f"panel `{entry['key']}`: not JSON: {e}") from None
    return out


def panel_recipe(props, text=None):
    """The recipe the panel describes: the recipe shown (the preset's, or a live tree's
    stored one), the panel's changes since, then the settings text (``text``, else the
    panel's). Raises
    ``settings.SettingsError`` or ``sylva.SylvaError``."""
    sylva = _state["sylva"]
    if props.base:
        recipe = sylva.Recipe.from_toml(props.base)
    else:
        recipe = sylva.Recipe.preset(props.preset)
    settings.apply(sylva, recipe, panel_changes(props))
    text = props.settings if text is None else text
    return settings.apply(sylva, recipe, settings.parse(text))


def _report_failure(op, e):
    op.report({"ERROR"}, f"sylva: {e}")
    return {"CANCELLED"}


class SYLVA_OT_grow(bpy.types.Operator):
    """Grow a sylva tree from a preset and build it as native objects"""

    bl_idname = "sylva.grow"
    bl_label = "Grow"
    bl_options = {"REGISTER", "UNDO"}

    preset: StringProperty(name="Preset", default="wp-quaking-aspen")
    seed: IntProperty(name="Seed", description="-1: the recipe's seed", default=-1, min=-1)
    settings: StringProperty(name="Settings", description="key=value lines or a TOML overlay")
    use_panel: BoolProperty(name="Use panel", default=False, options={"HIDDEN", "SKIP_SAVE"})

    def execute(self, context):
        sylva = _state["sylva"]
        try:
            if self.preset not in sylva.presets():
                raise settings.SettingsError(f"unknown preset `{self.preset}`")
            props = context.scene.sylva
            if self.use_panel and self.preset == props.preset:
                recipe = panel_recipe(props, self.settings)
            else:
                recipe = sylva.Recipe.preset(self.preset)
                if self.use_panel:
                    settings.apply(sylva, recipe, panel_changes(props))
                settings.apply(sylva, recipe, settings.parse(self.settings))
            tree = recipe.grow(seed=None if self.seed < 0 else self.seed)
        except (sylva.SylvaError, settings.SettingsError) as e:
            return _report_failure(self, e)
        try:
            root = build.build(tree, context)
        except Exception as e:  # a Blender error while building: a report, not a traceback
            return _report_failure(self, f"building the tree in Blender failed: {e!r}")
        _select(context, [root])
        self.report({"INFO"}, f"sylva: grew {recipe.name} ({tree.triangles} triangles)")
        return {"FINISHED"}


class SYLVA_OT_regrow(bpy.types.Operator):
    """Grow the selected sylva trees again from their stored recipes (with the changes
    given), replacing their meshes in place"""

    bl_idname = "sylva.regrow"
    bl_label = "Re-grow selected"
    bl_options = {"REGISTER", "UNDO"}

    seed: IntProperty(name="Seed", description="-1: the stored seed", default=-1, min=-1)
    settings: StringProperty(name="Settings", description="key=value lines or a TOML overlay")
    use_panel: BoolProperty(name="Use panel", default=False, options={"HIDDEN", "SKIP_SAVE"})

    def execute(self, context):
        sylva = _state["sylva"]
        roots = []
        for obj in context.selected_objects or ([context.object] if context.object else []):
            root = build.tree_root(obj)
            if root is not None and root not in roots:
                roots.append(root)
        if not roots:
            self.report({"ERROR"}, "sylva: no sylva tree is selected")
            return {"CANCELLED"}
        grown = []
        try:
            for root in roots:
                recipe = sylva.Recipe.from_toml(root[build.RECIPE_PROP])
                if self.use_panel:
                    settings.apply(sylva, recipe, panel_changes(context.scene.sylva))
                settings.apply(sylva, recipe, settings.parse(self.settings))
                seed = int(root.get(build.SEED_PROP, recipe.seed)) if self.seed < 0 else self.seed
                grown.append((root, recipe.grow(seed=seed)))
        except (sylva.SylvaError, settings.SettingsError) as e:
            return _report_failure(self, e)
        try:
            for root, tree in grown:
                build.build(tree, context, root=root)
        except Exception as e:  # a Blender error while building: a report, not a traceback
            return _report_failure(self, f"building the tree in Blender failed: {e!r}")
        _select(context, roots)
        return {"FINISHED"}


class SYLVA_OT_export(bpy.types.Operator, ExportHelper):
    """Write the active sylva tree as the engine writes it (glTF with LODs and the wind
    clip, OBJ, PLY, POV), grown again from the recipe stored on it"""

    bl_idname = "sylva.export"
    bl_label = "Export"

    filename_ext = ".glb"
    check_extension = None  # any extension the engine writes; .glb when none
    filter_glob: StringProperty(default="*.glb;*.gltf;*.obj;*.ply;*.pov", options={"HIDDEN"})

    def execute(self, context):
        sylva = _state["sylva"]
        root = build.tree_root(context.object)
        if root is None:
            self.report({"ERROR"}, "sylva: the active object is not a sylva tree")
            return {"CANCELLED"}
        try:
            recipe = sylva.Recipe.from_toml(root[build.RECIPE_PROP])
            tree = recipe.grow(seed=int(root.get(build.SEED_PROP, recipe.seed)))
            tree.save(self.filepath)
        except (sylva.SylvaError, OSError, ValueError) as e:
            return _report_failure(self, e)
        self.report({"INFO"}, f"sylva: wrote {self.filepath}")
        return {"FINISHED"}


def _select(context, roots):
    for obj in context.view_layer.objects:
        obj.select_set(False)
    for root in roots:
        root.select_set(True)
    context.view_layer.objects.active = roots[-1]


class VIEW3D_PT_sylva(bpy.types.Panel):
    """View3D > Sidebar > sylva: preset, seed, Grow, Re-grow selected, Export and the
    recipe's mesh, leaves, wind and lod settings."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "sylva"
    bl_label = "sylva"

    def draw(self, context):
        props = context.scene.sylva
        col = self.layout.column()
        col.prop(props, "preset")
        col.prop(props, "seed")
        col.prop(props, "settings")
        row = col.row()
        op = row.operator("sylva.grow")
        op.preset, op.seed, op.settings, op.use_panel = (
            props.preset,
            props.seed,
            props.settings,
            True,
        )
        op = row.operator("sylva.regrow")
        op.settings, op.use_panel = props.settings, True
        col.operator("sylva.export")
        row = col.row()
        row.prop(props, "live")
        if props.live and props.live_tree:
            row.label(text=props.live_tree)
        if props.live_status:
            icon = "ERROR" if props.live_status.startswith("error") else "INFO"
            col.label(text=props.live_status, icon=icon)
        for section in SECTIONS:
            box = col.box()
            if section == "generator":
                box.label(text=f"generator ({props.generator or '?'})")
            else:
                box.label(text=section)
            for entry in _state["entries"]:
                if entry["section"] == section and entry.get("generator") in (
                    None,
                    props.generator,
                ):
                    box.prop(props, _attr(entry))


def settings_class(sylva):
    """The scene's property group, with one property per schema entry the panel shows
    (``_in_panel``), the Live toggle and its status."""
    entries = [e for e in sylva.schema() if _in_panel(e)]
    _state["entries"] = entries
    presets = sylva.presets()
    first = "wp-quaking-aspen" if "wp-quaking-aspen" in presets else presets[0]
    annotations = {
        "preset": EnumProperty(
            name="Preset",
            items=[(p, p, "") for p in presets],
            default=first,
            update=_load_preset,
        ),
        "seed": IntProperty(
            name="Seed",
            description="-1: the recipe's seed",
            default=-1,
            min=-1,
            update=_changed,
        ),
        "settings": StringProperty(name="Settings", description="key=value lines", update=_changed),
        "live": BoolProperty(
            name="Live",
            description="Regrow the active sylva tree in place about 0.3 s after every "
            "change of these settings (in the background)",
            default=False,
            update=live.toggled,
            options=set(),
        ),
        "live_tree": StringProperty(name="Live tree", options={"HIDDEN"}),
        "live_id": StringProperty(options={"HIDDEN"}),
        "live_status": StringProperty(name="Live status", options={"HIDDEN"}),
        "shown": StringProperty(options={"HIDDEN"}),
        "base": StringProperty(options={"HIDDEN"}),
        "generator": StringProperty(
            options={"HIDDEN"}, default=sylva.Recipe.preset(first).get("generator.type") or ""
        ),
    }
    for entry in entries:
        annotations[_attr(entry)] = _schema_property(entry)
    return type("SylvaSettings", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


CLASSES = (SYLVA_OT_grow, SYLVA_OT_regrow, SYLVA_OT_export, VIEW3D_PT_sylva)


def register(sylva):
    _state["sylva"] = sylva
    cls = settings_class(sylva)
    _state["settings_class"] = cls
    bpy.utils.register_class(cls)
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.sylva = PointerProperty(type=cls)
    live.register(sylva)
    if build.pack_images not in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.append(build.pack_images)


def unregister():
    live.unregister()
    if build.pack_images in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.remove(build.pack_images)
    del bpy.types.Scene.sylva
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
    if _state["settings_class"] is not None:
        bpy.utils.unregister_class(_state["settings_class"])
        _state["settings_class"] = None
