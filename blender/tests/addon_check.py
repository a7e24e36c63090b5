"""Run inside Blender by crates/sylva-py/tests/test_blender.py:

    blender -b --factory-startup --python-exit-code 1 --python addon_check.py -- ZIP OUT.json

Installs and enables the add-on from ZIP, grows an L-system and a Weber-Penn preset (with
LOD levels) through ``bpy.ops.sylva.grow`` and checks the objects, materials, images,
vertex and triangle counts against the Python API, LOD visibility, the bark's Base
Color image, the panel's schema settings, re-growing, and that bad settings cancel with
an error report and leave the tree. Any failed check raises (exit status 1); the
numbers measured go to OUT.json."""

import json
import sys
import time
import types
from pathlib import Path

import bpy
import numpy as np

zip_path, out_path = sys.argv[sys.argv.index("--") + 1 :][:2]
result = {}

bpy.ops.preferences.addon_install(filepath=zip_path)
bpy.ops.preferences.addon_enable(module="sylva_blender")
import sylva  # noqa: E402  (importable once the add-on is enabled)
from sylva_blender import build, preview  # noqa: E402

result["sylva_file"] = sylva.__file__


def lod_objects(root):
    """{k: [mesh objects of LOD k]} under ``root``."""
    out = {}
    for obj in root.children:
        if "sylva_lod" in obj:
            out.setdefault(obj["sylva_lod"], []).append(obj)
    return out


def image_error(img, array):
    """The largest difference between a Blender image's pixels and the (H, W, C) uint8
    array it was made from, in 1/255 steps."""
    h, w, c = array.shape
    assert tuple(img.size) == (w, h), (img.name, tuple(img.size), (w, h))
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    got = px.reshape(h, w, 4)[::-1, :, :c]
    return float(np.abs(got * 255.0 - array).max())


def check_tree(root, recipe, label, pixels=False):
    """Checks the tree built under ``root`` against ``recipe`` grown by the Python API
    (with ``pixels``, also its first part's images against the part's arrays)."""
    tree = recipe.grow(seed=root[build.SEED_PROP])
    parts = tree.parts
    levels = lod_objects(root)
    budgets = recipe.get("lod.levels") or []
    assert sorted(levels) == list(range(max(1, len(budgets)))), (label, sorted(levels))
    lod0 = levels[0]
    assert len(lod0) == len(parts), (label, len(lod0), len(parts))
    verts = sum(len(o.data.vertices) for o in lod0)
    tris = sum(len(o.data.polygons) for o in lod0)
    assert all(len(p.vertices) == 3 for o in lod0 for p in o.data.polygons), label
    want_v = sum(len(p.vertices) for p in parts)
    want_t = sum(len(p.faces) for p in parts)
    assert (verts, tris) == (want_v, want_t), (label, verts, tris, want_v, want_t)
    mats = {s.material for objs in levels.values() for o in objs for s in o.material_slots}
    assert len(mats) == len({p.material["name"] for p in parts}), (label, mats)
    for objs in levels.values():  # every level uses the same materials
        assert {s.material for o in objs for s in o.material_slots} == mats, label
    images = {n.image for m in mats for n in m.node_tree.nodes if n.type == "TEX_IMAGE"}
    assert len(images) == sum(len(p.images) for p in parts), (label, len(images))
    for k, objs in levels.items():
        for o in objs:
            assert o.visible_get() == (k == 0), (label, o.name, k)
        if k > 0:
            lod_tris = sum(len(o.data.polygons) for o in objs)
            assert 0 < lod_tris <= budgets[k], (label, k, lod_tris, budgets[k])
    for part, obj in zip(parts, lod0):
        mat = obj.material_slots[0].material
        bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
        if "base_color" in part.images:
            links = bsdf.inputs["Base Color"].links
            assert links and links[0].from_node.type == "TEX_IMAGE", (label, part.name)
            assert links[0].from_node.image is not None, (label, part.name)
        if part.material["alpha_cutoff"] is not None:
            assert mat.blend_method == "CLIP", (label, part.name, mat.blend_method)
        for node in mat.node_tree.nodes:  # every map holds the part's pixels
            if node.type == "TEX_IMAGE" and part.name == parts[0].name and pixels:
                err = image_error(node.image, part.images[node.name])
                assert err < 0.51, (label, part.name, node.name, err)
        assert obj.data.uv_layers, (label, part.name)
        assert obj.data.polygons[0].use_smooth, (label, part.name)
    return {
        "vertices": verts,
        "triangles": tris,
        "objects": sum(len(v) for v in levels.values()),
        "materials": len(mats),
        "images": len(images),
        "lod_triangles": [sum(len(o.data.polygons) for o in levels[k]) for k in sorted(levels)],
    }


def grow(preset, text=""):
    t0 = time.perf_counter()
    assert bpy.ops.sylva.grow(preset=preset, settings=text) == {"FINISHED"}
    seconds = time.perf_counter() - t0
    root = bpy.context.view_layer.objects.active
    assert root is not None and build.RECIPE_PROP in root, preset
    return root, seconds


def expect_error(call, needle):
    """``call`` must fail with Blender's error report naming ``needle``."""
    try:
        call()
    except RuntimeError as e:  # bpy.ops raises the operator's ERROR report
        assert "Error" in str(e) and needle in str(e), str(e)
        return str(e).strip()
    raise AssertionError(f"expected an error naming {needle}")


# An L-system tree.
honda, _ = grow("lsys-honda-a")
result["lsys-honda-a"] = check_tree(
    honda, sylva.Recipe.preset("lsys-honda-a"), "honda", pixels=True
)

# A Weber-Penn tree with two LOD levels and wind.
aspen_settings = "lod.levels = [20000, 5000]\nmesh.sides = 6\nwind.preset = 'breeze'"
aspen, seconds = grow("wp-quaking-aspen", aspen_settings)
aspen_recipe = sylva.Recipe.preset("wp-quaking-aspen").set("lod.levels", [20000, 5000])
aspen_recipe.set("mesh.sides", 6).set("wind.preset", "breeze")
result["wp-quaking-aspen"] = check_tree(aspen, aspen_recipe, "aspen")
result["wp-quaking-aspen"]["grow_and_build_s"] = seconds


def _quat_matrix(q):
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def gltf_skinned(recipe, seed, sample):
    """The bark of LOD0 skinned by the glTF's own rig at key ``sample`` of its clip
    (linear blend skinning as a glTF viewer does it), +Y up."""
    glb = build.Glb(recipe.grow(seed=seed).to_glb())
    doc = glb.doc
    nodes = doc["nodes"]
    skin = doc["skins"][0]
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
    rot = {}
    anim = doc["animations"][0]
    for ch in anim["channels"]:
        rot[ch["target"]["node"]] = glb.accessor(anim["samplers"][ch["sampler"]]["output"])[sample]
    world = {}

    def matrix(i):
        if i not in world:
            m = np.eye(4)
            m[:3, 3] = nodes[i].get("translation", [0.0, 0.0, 0.0])
            if i in rot:
                m[:3, :3] = _quat_matrix(rot[i])
            world[i] = (matrix(parent[i]) if i in parent else np.eye(4)) @ m
        return world[i]

    ibm = glb.accessor(skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    skins = np.array([matrix(j) @ ibm[k] for k, j in enumerate(skin["joints"])])
    prim = glb.lod_meshes()[0]["primitives"][0]
    pos = glb.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
    joints = glb.accessor(prim["attributes"]["JOINTS_0"]).astype(np.int64)
    weights = glb.accessor(prim["attributes"]["WEIGHTS_0"]).astype(np.float64)
    hom = np.concatenate([pos, np.ones((len(pos), 1))], axis=1)
    out = np.zeros((len(pos), 4))
    for slot in range(joints.shape[1]):
        out += weights[:, slot, None] * np.einsum("vij,vj->vi", skins[joints[:, slot]], hom)
    return out[:, :3]


def check_wind(root, recipe, label):
    """One armature with the recipe's joints as bones, its clip as the one action, the
    scene's frame range the clip's, every mesh bound to it and moving with the wind."""
    rigs = [o for o in root.children if o.type == "ARMATURE"]
    assert len(rigs) == 1, (label, rigs)
    rig = rigs[0]
    joints = recipe.grow(seed=root[build.SEED_PROP]).report["joints"]
    assert len(rig.data.bones) == joints > 0, (label, len(rig.data.bones), joints)
    action = rig.animation_data.action
    assert action is not None and len(action.fcurves) == 4 * joints, label
    scene = bpy.context.scene
    fps, clip = recipe.get("wind.fps"), recipe.get("wind.clip_seconds")
    assert scene.render.fps == fps, (label, scene.render.fps)
    assert (scene.frame_start, scene.frame_end) == (1, round(clip * fps)), label
    assert tuple(int(f) for f in action.frame_range) == (1, 1 + round(clip * fps)), label
    meshes = [o for o in root.children if o.type == "MESH"]
    assert all(m.modifiers and m.modifiers[0].object == rig for m in meshes), label
    bark = next(o for o in meshes if o["sylva_lod"] == 0 and o.name.endswith("bark"))
    sample = round(clip * fps / 3)  # a key time of the clip
    scene.frame_set(1 + sample)
    ev = bark.evaluated_get(bpy.context.evaluated_depsgraph_get())
    got = np.empty(len(ev.data.vertices) * 3, dtype=np.float32)
    ev.data.vertices.foreach_get("co", got)
    want = gltf_skinned(recipe, root[build.SEED_PROP], sample)
    want = np.stack([want[:, 0], -want[:, 2], want[:, 1]], axis=1)  # +Y up to +Z up
    err = float(np.abs(got.reshape(-1, 3) - want).max())
    rest = np.empty(len(bark.data.vertices) * 3, dtype=np.float32)
    bark.data.vertices.foreach_get("co", rest)
    sway = float(np.abs(got - rest).max())
    assert err < 1e-3 and sway > 1e-3, (label, err, sway)
    scene.frame_set(1)
    return {"bones": joints, "actions": 1, "frames": scene.frame_end, "sway_m": sway, "err_m": err}


result["wind"] = check_wind(aspen, aspen_recipe, "aspen")
assert len(bpy.data.actions) == 1 and len(bpy.data.armatures) == 1

# Instanced leaves: realized into one mesh, every instance where the cards would be.
inst, _ = grow("wp-quaking-aspen", "leaves.mode = 'instanced'")
inst_tree = sylva.Recipe.preset("wp-quaking-aspen").set("leaves.mode", "instanced").grow()
((leaf_part, transforms),) = inst_tree.instances
inst_objs = {o.name.split("_LOD0_")[1]: o for o in inst.children if o["sylva_lod"] == 0}
assert set(inst_objs) == {p.name for p in inst_tree.parts} | {leaf_part.name}, inst_objs
leaf_mesh = inst_objs[leaf_part.name].data
assert len(leaf_mesh.vertices) == len(transforms) * len(leaf_part.vertices)
assert len(leaf_mesh.polygons) == len(transforms) * len(leaf_part.faces)
assert inst_objs[leaf_part.name].material_slots[0].material.blend_method == "CLIP"


def bounds(mesh):
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    return co.min(axis=0), co.max(axis=0)


cards = next(o for o in aspen.children if o.get("sylva_lod") == 0 and "leaf" in o.name)
lo, hi = bounds(cards.data)
ilo, ihi = bounds(leaf_mesh)
margin = 0.1 * (hi - lo)
assert np.all(ilo >= lo - margin) and np.all(ihi <= hi + margin), (lo, hi, ilo, ihi)
assert np.all(ihi - ilo > 0.5 * (hi - lo)), (lo, hi, ilo, ihi)  # spread like the crown
result["instanced_leaves"] = {"instances": len(transforms), "vertices": len(leaf_mesh.vertices)}
inst_coll = inst.users_collection[0]
build.clear(inst)  # what a re-grow removes, then the root and its collection
bpy.data.objects.remove(inst)
bpy.data.collections.remove(inst_coll)

# The recipe is stored on the tree: it reads back as the recipe grown.
assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == aspen_recipe.to_toml()


# Bad settings: an error report, no new objects, the previous trees untouched.
def data_counts():
    d = bpy.data
    return tuple(
        len(c) for c in (d.objects, d.meshes, d.materials, d.images, d.armatures, d.actions)
    )


before = data_counts()
result["errors"] = [
    expect_error(
        lambda: bpy.ops.sylva.grow(preset="lsys-honda-a", settings="mesh.sides = 1"), "mesh.sides"
    ),
    expect_error(
        lambda: bpy.ops.sylva.grow(preset="lsys-honda-a", settings="no.such.key = 3"), "no.such.key"
    ),
    expect_error(
        lambda: bpy.ops.sylva.grow(preset="lsys-honda-a", settings="mesh.sides"), "line 1"
    ),
    expect_error(lambda: bpy.ops.sylva.grow(preset="no-such-preset"), "no-such-preset"),
]
after = data_counts()
assert before == after, (before, after)
assert check_tree(aspen, aspen_recipe, "aspen after errors") == {
    k: v for k, v in result["wp-quaking-aspen"].items() if k != "grow_and_build_s"
}

# Re-grow selected: the same tree in place (same root, transform kept, nothing left over).
aspen.location = (3.0, 0.0, 0.0)
for obj in bpy.context.view_layer.objects:
    obj.select_set(False)
aspen.select_set(True)
bpy.context.view_layer.objects.active = aspen
assert bpy.ops.sylva.regrow() == {"FINISHED"}
assert (
    check_tree(aspen, aspen_recipe, "aspen regrown")["vertices"]
    == result["wp-quaking-aspen"]["vertices"]
)
assert tuple(aspen.location) == (3.0, 0.0, 0.0)
assert data_counts() == after
assert check_wind(aspen, aspen_recipe, "aspen regrown") == result["wind"]
# ... with a change, and a bad change that leaves it.
assert bpy.ops.sylva.regrow(settings="mesh.sides = 5") == {"FINISHED"}
aspen_recipe.set("mesh.sides", 5)
result["regrown_sides_5"] = check_tree(aspen, aspen_recipe, "aspen sides 5")
assert result["regrown_sides_5"]["vertices"] != result["wp-quaking-aspen"]["vertices"]
result["errors"].append(
    expect_error(lambda: bpy.ops.sylva.regrow(settings="leaves.alpha_cutoff = 2"), "alpha_cutoff")
)
assert check_tree(aspen, aspen_recipe, "aspen after a bad regrow") == result["regrown_sides_5"]

# The panel's settings come from the schema; a preset shows its values; a change applies.
props = bpy.context.scene.sylva
schema_keys = [
    e["key"] for e in sylva.schema() if e["section"] in ("mesh", "leaves", "wind", "lod")
]
assert all(hasattr(props, k.replace(".", "__")) for k in schema_keys), schema_keys
props.preset = "lsys-honda-b"
assert props.mesh__sides == sylva.Recipe.preset("lsys-honda-b").get("mesh.sides")
props.mesh__sides = 5
assert bpy.ops.sylva.grow(preset="lsys-honda-b", use_panel=True) == {"FINISHED"}
panel_tree = bpy.context.view_layer.objects.active
result["panel"] = check_tree(
    panel_tree, sylva.Recipe.preset("lsys-honda-b").set("mesh.sides", 5), "panel"
)
result["panel_keys"] = len(schema_keys)


class FakeLayout:
    """Records what a panel draws (there is no UI to draw into when headless)."""

    def __init__(self, log):
        self.log = log

    def column(self):
        return self

    def row(self):
        return self

    def box(self):
        return self

    def label(self, text="", icon="NONE"):
        self.log.append(("label", text))

    def prop(self, data, attr):
        assert attr in data.bl_rna.properties, attr
        self.log.append(("prop", attr))

    def operator(self, idname):
        op = types.SimpleNamespace()
        self.log.append(("operator", idname, op))
        return op


drawn = []
bpy.types.VIEW3D_PT_sylva.draw(types.SimpleNamespace(layout=FakeLayout(drawn)), bpy.context)
drawn_props = [d[1] for d in drawn if d[0] == "prop"]
assert drawn_props[:4] == ["preset", "seed", "settings", "live"], drawn_props[:4]
# The generator's own settings (the shown preset's generator: lsystem), from the schema
# less the type and the model files, then the other sections.
generator_attrs = [
    "gen_lsystem__" + e["key"].split(".", 1)[1].replace(".", "__")
    for e in sylva.schema()
    if e["section"] == "generator"
    and e["generator"] == "lsystem"
    and e["key"] != "generator.type"
    and e["kind"]["type"] != "path"
]
assert len(generator_attrs) >= 10, generator_attrs
assert drawn_props[4:] == generator_attrs + [k.replace(".", "__") for k in schema_keys], drawn_props
ops = {d[1]: d[2] for d in drawn if d[0] == "operator"}
assert set(ops) == {"sylva.grow", "sylva.regrow", "sylva.export"}, ops
assert ops["sylva.grow"].preset == "lsys-honda-b" and ops["sylva.grow"].use_panel, ops
labels = [d[1] for d in drawn if d[0] == "label"]
assert labels == ["generator (lsystem)", "mesh", "leaves", "wind", "lod"], drawn
# A generator setting in the panel grows into the tree.
props.gen_lsystem__angle = 30.0
assert bpy.ops.sylva.grow(preset="lsys-honda-b", use_panel=True) == {"FINISHED"}
panel_tree = bpy.context.view_layer.objects.active
want = sylva.Recipe.preset("lsys-honda-b").set("mesh.sides", 5).set("generator.angle", 30.0)
assert sylva.Recipe.from_toml(panel_tree[build.RECIPE_PROP]).to_toml() == want.to_toml()

# A space-colonization tree, rendered alone at 128 x 128 (Cycles on the CPU).
colonize, seconds = grow("colonize-broadleaf")
result["colonize-broadleaf"] = check_tree(
    colonize, sylva.Recipe.preset("colonize-broadleaf"), "colonize"
)
result["colonize-broadleaf"]["grow_and_build_s"] = seconds


t0 = time.perf_counter()
px = preview.render(colonize, str(Path(out_path).with_name("render.png")), 128, 4)
covered = px[:, 3] > 0.5
result["render"] = {
    "seconds": time.perf_counter() - t0,
    "covered": float(covered.mean()),
    "mean_rgb": px[covered, :3].mean(axis=0).tolist(),
}
assert 0.02 < result["render"]["covered"] < 0.9, result["render"]
assert px[covered, :3].std(axis=0).max() > 0.01, result["render"]  # not one flat colour

# Export: the engine's own file of the active tree; a format it does not write is an error.
glb_path = str(Path(out_path).with_name("colonize.glb"))
assert bpy.ops.sylva.export(filepath=glb_path) == {"FINISHED"}
with open(glb_path, "rb") as f:
    assert f.read() == sylva.Recipe.preset("colonize-broadleaf").grow().to_glb()
bad_path = str(Path(out_path).with_name("colonize.xyz"))
result["errors"].append(expect_error(lambda: bpy.ops.sylva.export(filepath=bad_path), "xyz"))
assert not Path(bad_path).exists()

# Disabling and enabling again leaves a working add-on.
bpy.ops.preferences.addon_disable(module="sylva_blender")
assert "sylva" not in bpy.types.Scene.bl_rna.properties
assert not hasattr(bpy.types, "VIEW3D_PT_sylva") and not hasattr(bpy.types, "SYLVA_OT_grow")
bpy.ops.preferences.addon_enable(module="sylva_blender")
assert bpy.ops.sylva.grow(preset="lsys-honda-a") == {"FINISHED"}
assert bpy.context.scene.sylva.preset in sylva.presets()

# Saved and opened again (a later session): the images were packed on save, and the
# recipe stored on the tree grows it again.
blend = str(Path(out_path).with_name("trees.blend"))
aspen_name, aspen_vertices = aspen.name, result["regrown_sides_5"]["vertices"]
bpy.ops.wm.save_as_mainfile(filepath=blend)
bpy.ops.wm.open_mainfile(filepath=blend)
sylva_images = [img for img in bpy.data.images if "sylva_image" in img]
assert sylva_images and all(img.packed_file is not None for img in sylva_images)
assert all(img.has_data or img.pixels[:4] is not None for img in sylva_images)
result["packed_images"] = len(sylva_images)
aspen = bpy.data.objects[aspen_name]
for obj in bpy.context.view_layer.objects:
    obj.select_set(False)
aspen.select_set(True)
bpy.context.view_layer.objects.active = aspen
assert bpy.ops.sylva.regrow() == {"FINISHED"}
assert check_tree(aspen, aspen_recipe, "aspen reopened")["vertices"] == aspen_vertices
honda = bpy.data.objects["lsys-honda-a"]
check_tree(honda, sylva.Recipe.preset("lsys-honda-a"), "honda reopened", pixels=True)

# Live mode on the aspen (wind, two LOD levels): panel changes regrow it in place.
from sylva_blender import live  # noqa: E402


def mesh_co(obj):
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    return co


def lod0(root, part):
    return next(o for o in root.children if o.get("sylva_lod") == 0 and o.name.endswith(part))


view_layer = bpy.context.view_layer
props = bpy.context.scene.sylva
for obj in view_layer.objects:
    obj.select_set(False)
aspen.select_set(True)
view_layer.objects.active = aspen
aspen.location = (1.0, 2.0, 0.5)
bark0, leaf0 = lod0(aspen, "bark"), lod0(aspen, "leaf_cards")
bark0.modifiers.new("user_displace", "DISPLACE").strength = 0.0
child_names = sorted(o.name for o in aspen.children)
live_recipe = sylva.Recipe.from_toml(aspen[build.RECIPE_PROP])
props.live = True
assert props.live_tree == aspen.name, props.live_tree
assert props.mesh__sides == 5 and props.preset == "wp-quaking-aspen"  # the tree's recipe
assert abs(props.gen_weber_penn__ratio - live_recipe.get("generator.ratio")) < 1e-6
assert live.pump(60) and props.live_status == f"Live: {aspen.name}", props.live_status


def live_change(set_value, obj):
    """Sets a panel value and pumps until the live regrow is built; the seconds from
    the change to the mesh replaced, and whether ``obj``'s vertices changed."""
    before = mesh_co(obj)
    t0 = time.perf_counter()
    set_value()
    assert live.pump(30), "live regrow did not finish"
    seconds = time.perf_counter() - t0
    after = mesh_co(obj)
    assert props.live_status.startswith("Live:"), props.live_status
    changed = len(after) != len(before) or not np.array_equal(after, before)
    return seconds, changed, live.stats()


live_result = {}
# A leaf setting.
s, changed, st = live_change(lambda: setattr(props, "leaves__shape", "lanceolate"), leaf0)
live_recipe.set("leaves.shape", "lanceolate")
assert changed and s < 2.0, (s, st)
assert "generate" not in st["stages"], st  # the session kept the skeleton
live_result["leaf"] = {"seconds": s, **st}
# A generator setting.
s, changed, st = live_change(lambda: setattr(props, "gen_weber_penn__ratio", 0.02), bark0)
live_recipe.set("generator.ratio", 0.02)
assert changed and s < 2.0, (s, st)
assert "generate" in st["stages"], st
live_result["generator"] = {"seconds": s, **st}
# Replaced in place: the same objects, names, transform, modifiers and selection.
assert sorted(o.name for o in aspen.children) == child_names
assert lod0(aspen, "bark") == bark0 and lod0(aspen, "leaf_cards") == leaf0
assert bark0.modifiers[0].name == "wind" and bark0.modifiers["user_displace"].type == "DISPLACE"
assert tuple(aspen.location) == (1.0, 2.0, 0.5)
assert aspen.select_get() and view_layer.objects.active == aspen
assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == live_recipe.to_toml()
live_result["tree"] = check_tree(aspen, live_recipe, "aspen live")
live_result["wind"] = check_wind(aspen, live_recipe, "aspen live")
assert len(bpy.data.actions) == 1 and len(bpy.data.armatures) == 1
live_counts = data_counts()

# A newer change while a regrow runs: the stale result is dropped, the latest is built.
dropped = live.stats()["dropped"]
props.gen_weber_penn__ratio = 0.025
t0 = time.perf_counter()
while not live.running() and time.perf_counter() - t0 < 10:
    live.pump(0.005)
assert live.running()
props.gen_weber_penn__ratio = 0.03
assert live.pump(30)
live_recipe.set("generator.ratio", 0.03)
assert live.stats()["dropped"] > dropped, live.stats()
assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == live_recipe.to_toml()
assert data_counts() == live_counts

# Bad values: an error in the panel's status, the tree as it was, no traceback.
bark_co = mesh_co(bark0)
live_result["errors"] = []
for attr, value, needle in [
    ("settings", "mesh.sides = 1", "mesh.sides"),
    ("lod__levels", "[20000, oops", "lod.levels"),
]:
    good = getattr(props, attr)
    setattr(props, attr, value)
    assert live.pump(30)
    assert props.live_status.startswith("error") and needle in props.live_status, props.live_status
    assert np.array_equal(mesh_co(bark0), bark_co) and data_counts() == live_counts
    assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == live_recipe.to_toml()
    live_result["errors"].append(props.live_status)
    setattr(props, attr, good)
    assert live.pump(30) and props.live_status.startswith("Live:"), props.live_status

# In Edit Mode the result waits: the mesh is replaced back in Object Mode.
view_layer.objects.active = bark0
bpy.ops.object.mode_set(mode="EDIT")
props.leaves__shape = "ovate"
assert not live.pump(2.0) and "Object Mode" in props.live_status, props.live_status
bpy.ops.object.mode_set(mode="OBJECT")
view_layer.objects.active = aspen
assert live.pump(30) and props.live_status.startswith("Live:"), props.live_status
live_recipe.set("leaves.shape", "ovate")
assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == live_recipe.to_toml()

# Renamed, the live tree is still found (by its tag) and regrown.
aspen.name = "my aspen"
props.gen_weber_penn__ratio = 0.035
assert live.pump(30) and props.live_tree == "my aspen", (props.live_tree, props.live_status)
live_recipe.set("generator.ratio", 0.035)
assert sylva.Recipe.from_toml(aspen[build.RECIPE_PROP]).to_toml() == live_recipe.to_toml()
assert lod0(aspen, "bark") == bark0 and tuple(aspen.location) == (1.0, 2.0, 0.5)

# Live off: nothing more happens.
props.live = False
assert live.idle() and props.live_tree == ""
leaf_co = mesh_co(leaf0)
props.leaves__shape = "lanceolate"
assert live.pump(0.5) and np.array_equal(mesh_co(leaf0), leaf_co)

# Live on with no sylva tree active: a tree is grown from the panel and becomes live.
props.preset = "lsys-honda-a"
for obj in view_layer.objects:
    obj.select_set(False)
view_layer.objects.active = None
n_objects = len(bpy.data.objects)
props.live = True
assert live.pump(30)
new_root = view_layer.objects.active
assert new_root is not None and props.live_tree == new_root.name, props.live_tree
assert len(bpy.data.objects) > n_objects
check_tree(new_root, sylva.Recipe.preset("lsys-honda-a"), "live new tree")
props.live = False
result["live"] = live_result

with open(out_path, "w") as f:
    json.dump(result, f, indent=1)
print("addon_check: ok")
