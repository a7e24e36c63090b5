"""Builds native Blender data from a grown ``sylva.Tree``: one mesh object per part and
LOD level (vertices, faces, normals and UVs copied with ``foreach_set``, smooth shading
with the engine's normals as custom split normals), Principled BSDF materials wired to
the part's images and shared by every LOD level, and an Empty that holds the recipe.

Coordinates: sylva is +Y up (as glTF); Blender is +Z up, so (x, y, z) becomes
(x, -z, y), the conversion Blender's glTF importer makes. UVs have glTF's top-left
origin and are flipped to Blender's bottom-left one.

LOD0 is ``tree.parts``, plus ``tree.instances`` (instanced leaves) realized into one
mesh per instanced part: Blender has no per-instance rotation and scale short of
geometry nodes. The Python API exposes neither the other levels nor the wind
rig, so levels 1.. (nodes ``sylva_LOD<k>``), the skin (joints, inverse bind matrices,
per-vertex joints and weights) and the wind clip are read from the tree's own binary
glTF (``tree.to_glb()``), parsed in memory here: no file and no glTF importer. The rig
is an armature whose bones rest along +Y (their rest frames are the armature's, as the
glTF joints, which have translations only), so the clip's joint rotations become the
pose bones' quaternions after the axis change; the meshes get one vertex group per
joint and an Armature modifier."""

import hashlib
import json
import re
import struct

import bpy
import numpy as np
from bpy.app.handlers import persistent

RECIPE_PROP = "sylva_recipe"
SEED_PROP = "sylva_seed"
IMAGE_PROP = "sylva_image"

_COMPONENTS = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Level:
    """One LOD level: a list of ``(part name, vertices, faces, normals, uvs, skin)``,
    ``skin`` being ``(joints (V, 4), weights (V, 4))`` or None."""

    def __init__(self, parts):
        self.parts = parts


class Glb:
    """The JSON and binary chunk of a tree's binary glTF."""

    def __init__(self, data):
        json_len = struct.unpack_from("<I", data, 12)[0]
        self.doc = json.loads(data[20 : 20 + json_len])
        self.binary = data[28 + json_len :]

    def accessor(self, index):
        """Accessor ``index`` as an array (rows of its width)."""
        doc = self.doc
        acc = doc["accessors"][index]
        view = doc["bufferViews"][acc["bufferView"]]
        dtype = np.dtype(_COMPONENTS[acc["componentType"]])
        width = _WIDTHS[acc["type"]]
        stride = view.get("byteStride", dtype.itemsize * width)
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        shape, strides = (acc["count"], width), (stride, dtype.itemsize)
        rows = np.ndarray(shape, dtype, self.binary, start, strides)
        return rows.copy() if width > 1 else rows[:, 0].copy()

    def lod_meshes(self):
        """``{k: glTF mesh}`` of the nodes ``sylva_LOD<k>`` (or ``sylva``, level 0)."""
        found = {}
        for node in self.doc["nodes"]:
            m = re.fullmatch(r"sylva(?:_LOD(\d+))?", node.get("name", ""))
            if m and "mesh" in node:
                found[int(m.group(1) or 0)] = self.doc["meshes"][node["mesh"]]
        return found


def needs_glb(recipe):
    """Whether the tree's glTF is read: for LOD levels past 0 or for the wind rig."""
    return bool(recipe.get("lod.levels")) or recipe.get("wind.preset") not in (None, "none")


def realize(part, transforms):
    """``(name, vertices, faces, normals, uvs, None)``: every instance of ``part`` in one
    mesh, its vertices moved by each ``(4, 4)`` transform (column vectors, as the
    engine's), the normals by the inverse transpose."""
    v = np.asarray(part.vertices, dtype=np.float32)
    m = np.asarray(transforms, dtype=np.float32)
    lin = m[:, :3, :3]
    verts = np.einsum("kij,vj->kvi", lin, v) + m[:, None, :3, 3]
    normals = np.einsum("kij,vj->kvi", np.linalg.inv(lin).transpose(0, 2, 1), part.normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-12)
    faces = part.faces[None].astype(np.int64) + (np.arange(len(m)) * len(v))[:, None, None]
    uvs = None if part.uvs is None else np.tile(part.uvs, (len(m), 1))
    return (
        part.name,
        verts.reshape(-1, 3),
        faces.reshape(-1, 3).astype(np.uint32),
        normals.reshape(-1, 3).astype(np.float32),
        uvs,
        None,
    )


def lod_levels(parts, glb, instances=()):
    """The tree's levels: LOD0 from its ``parts`` (and its ``instances``, realized),
    the others from its glTF; with a wind rig, every level's joints and weights from the
    glTF (instanced organs are not bound to the rig)."""
    names = [p.name for p in parts]
    meshes = glb.lod_meshes() if glb is not None else {}

    def skin(prim):
        attrs = prim["attributes"]
        if "JOINTS_0" not in attrs or "WEIGHTS_0" not in attrs:
            return None
        return glb.accessor(attrs["JOINTS_0"]), glb.accessor(attrs["WEIGHTS_0"])

    level0 = []
    for j, p in enumerate(parts):
        prims = meshes.get(0, {"primitives": []})["primitives"]
        level0.append(
            (
                p.name,
                p.vertices,
                p.faces,
                p.normals,
                p.uvs,
                skin(prims[j]) if j < len(prims) else None,
            )
        )
    level0.extend(realize(part, transforms) for part, transforms in instances)
    levels = [Level(level0)]
    for k in sorted(meshes):
        if k == 0:
            continue
        level = []
        for j, prim in enumerate(meshes[k]["primitives"]):
            attrs = prim["attributes"]
            faces = glb.accessor(prim["indices"]).astype(np.uint32).reshape(-1, 3)
            uvs = glb.accessor(attrs["TEXCOORD_0"]) if "TEXCOORD_0" in attrs else None
            name = names[j] if j < len(names) else f"part{j}"
            positions, normals = glb.accessor(attrs["POSITION"]), glb.accessor(attrs["NORMAL"])
            level.append((name, positions, faces, normals, uvs, skin(prim)))
        levels.append(Level(level))
    return levels


def _zup(a):
    a = np.asarray(a, dtype=np.float32)
    return np.stack([a[:, 0], -a[:, 2], a[:, 1]], axis=1)


def make_mesh(name, vertices, faces, normals, uvs):
    """A Blender mesh from the arrays of one part (same vertex and triangle counts)."""
    n_v, n_t = len(vertices), len(faces)
    me = bpy.data.meshes.new(name)
    me.vertices.add(n_v)
    me.vertices.foreach_set("co", _zup(vertices).ravel())
    me.loops.add(3 * n_t)
    me.loops.foreach_set("vertex_index", np.asarray(faces, dtype=np.int32).ravel())
    me.polygons.add(n_t)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * n_t, 3, dtype=np.int32))
    try:  # read-only (and implied by loop_start) from Blender 4.0
        me.polygons.foreach_set("loop_total", np.full(n_t, 3, dtype=np.int32))
    except (AttributeError, TypeError, RuntimeError):
        pass
    if uvs is not None:
        uv = np.array(uvs, dtype=np.float32)
        uv[:, 1] = 1.0 - uv[:, 1]
        layer = me.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", uv[np.asarray(faces).ravel()].ravel())
    me.polygons.foreach_set("use_smooth", np.ones(n_t, dtype=bool))
    me.update(calc_edges=True)
    if hasattr(me, "use_auto_smooth"):  # needed for custom normals before Blender 4.1
        me.use_auto_smooth = True
    if n_v:
        me.normals_split_custom_set_from_vertices(_zup(normals))
    return me


def make_image(name, array, non_color):
    """A Blender image from an (H, W, C) uint8 array. It is packed into the .blend when
    the file is saved (``pack_images``, a save handler), not here: packing encodes a
    PNG, ≈ 0.04 s per 1024² image, which a grow need not wait for."""
    h, w, c = array.shape
    img = bpy.data.images.new(name, w, h, alpha=(c == 4))
    px = np.ones((h, w, 4), dtype=np.float32)
    px[:, :, :c] = array[::-1] / np.float32(255.0)
    if non_color:  # before the pixels: changing it reloads (blanks) a generated image
        img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    img[IMAGE_PROP] = 1
    return img


@persistent
def pack_images(*_args):
    """Packs the images sylva made that are not packed yet (``save_pre`` handler), so
    a saved .blend keeps them."""
    for img in bpy.data.images:
        if IMAGE_PROP in img and img.packed_file is None and img.has_data:
            img.pack()


def make_material(name, material, images):
    """A Principled BSDF material: the base color image feeds Base Color (and Alpha,
    clipped at the part's cutoff), the normal map a Normal Map node, the
    occlusion-roughness-metallic map Roughness (G) and Metallic (B)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = material["base_color"]
    bsdf.inputs["Metallic"].default_value = material["metallic"]
    bsdf.inputs["Roughness"].default_value = material["roughness"]
    mat.use_backface_culling = not material["double_sided"]
    x = bsdf.location.x - 400
    if "base_color" in images:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.name = tex.label = "base_color"
        tex.image = images["base_color"]
        tex.location = (x, 300)
        nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
        if material["alpha_cutoff"] is not None:
            nt.links.new(tex.outputs["Alpha"], bsdf.inputs["Alpha"])
    if material["alpha_cutoff"] is not None:
        try:
            mat.blend_method = "CLIP"
            mat.alpha_threshold = material["alpha_cutoff"]
        except TypeError:  # Blender 4.2+: no CLIP; EEVEE Next dithers
            mat.surface_render_method = "DITHERED"
    if "normal" in images:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.name = tex.label = "normal"
        tex.image = images["normal"]
        tex.location = (x - 300, -300)
        nmap = nt.nodes.new("ShaderNodeNormalMap")
        nmap.location = (x, -300)
        nt.links.new(tex.outputs["Color"], nmap.inputs["Color"])
        nt.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    if "occlusion_roughness_metallic" in images:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.name = tex.label = "occlusion_roughness_metallic"
        tex.image = images["occlusion_roughness_metallic"]
        tex.location = (x - 300, 0)
        sep = nt.nodes.new("ShaderNodeSeparateColor")
        sep.location = (x, 0)
        nt.links.new(tex.outputs["Color"], sep.inputs[0])
        nt.links.new(sep.outputs[1], bsdf.inputs["Roughness"])
        nt.links.new(sep.outputs[2], bsdf.inputs["Metallic"])
    return mat


def _quat_zup(q):
    """glTF quaternions (x, y, z, w), +Y up, as Blender's (w, x, y, z), +Z up."""
    return np.stack([q[:, 3], q[:, 0], -q[:, 2], q[:, 1]], axis=1)


def _joints(glb):
    """The rig of the glTF's first skin: ``(joint nodes, bone names, heads (J, 3) +Z up,
    parent bone index or -1 per bone)``."""
    doc = glb.doc
    nodes = doc["nodes"]
    joints = doc["skins"][0]["joints"]
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
    world = {}

    def rest(i):
        if i not in world:
            t = np.array(nodes[i].get("translation", [0.0, 0.0, 0.0]), dtype=np.float64)
            world[i] = t + (rest(parent[i]) if i in parent else 0.0)
        return world[i]

    heads = _zup(np.array([rest(j) for j in joints], dtype=np.float32))
    names = [nodes[j].get("name", f"joint_{k}") for k, j in enumerate(joints)]
    index = {j: k for k, j in enumerate(joints)}
    parents = []
    for j in joints:
        p = parent.get(j)
        while p is not None and p not in index:
            p = parent.get(p)
        parents.append(-1 if p is None else index[p])
    return joints, names, heads, parents


def _same_bones(arm, names, heads, parents):
    """Whether the armature ``arm`` already has exactly these bones (names, rest heads,
    parents): live mode then keeps it and only replaces the action."""
    bones = arm.bones
    if [b.name for b in bones] != names:
        return False
    have = np.array([tuple(b.head_local) for b in bones], dtype=np.float32).reshape(-1, 3)
    if len(have) != len(heads) or not np.allclose(have, heads, atol=1e-6):
        return False
    index = {n: k for k, n in enumerate(names)}
    return [index[b.parent.name] if b.parent else -1 for b in bones] == parents


def _make_armature(name, names, heads, parents, context, obj):
    """New armature data for ``obj`` with one bone per joint, pointing along +Y (so its
    rest frame is the armature's and the clip's rotations apply unchanged)."""
    extent = float(np.ptp(heads, axis=0).max()) if len(heads) else 1.0
    length = max(extent / 50.0, 0.01)
    arm = bpy.data.armatures.new(name)
    previous_data = obj.data
    obj.data = arm
    if previous_data is not None and previous_data.users == 0:
        bpy.data.armatures.remove(previous_data)
        arm.name = name
    view_layer = context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bones = []
    for k, bone in enumerate(names):
        eb = arm.edit_bones.new(bone)
        eb.head = heads[k]
        eb.tail = heads[k] + np.array([0.0, length, 0.0], dtype=np.float32)
        bones.append(eb)
    for eb, p in zip(bones, parents):
        if p >= 0:
            eb.parent = bones[p]
    bpy.ops.object.mode_set(mode="OBJECT")
    view_layer.objects.active = previous
    for pb in obj.pose.bones:
        pb.rotation_mode = "QUATERNION"
    return arm


def _make_action(glb, fps, name, joints):
    """The glTF's first animation as an action of joint rotations (linear keys), and its
    length in seconds; ``(None, 0.0)`` when the glTF has none."""
    doc = glb.doc
    if not doc.get("animations"):
        return None, 0.0
    nodes = doc["nodes"]
    anim = doc["animations"][0]
    action = bpy.data.actions.new(name)
    end = 0.0
    for ch in anim["channels"]:
        target = ch["target"]
        if target.get("path") != "rotation" or target.get("node") not in joints:
            continue
        sampler = anim["samplers"][ch["sampler"]]
        times = glb.accessor(sampler["input"]).astype(np.float64)
        end = max(end, float(times[-1]))
        quats = _quat_zup(glb.accessor(sampler["output"]))
        bone = nodes[target["node"]].get("name")
        frames = 1.0 + times * fps
        for i in range(4):
            fc = action.fcurves.new(
                f'pose.bones["{bone}"].rotation_quaternion', index=i, action_group=bone
            )
            fc.keyframe_points.add(len(times))
            co = np.stack([frames, quats[:, i]], axis=1).astype(np.float32)
            fc.keyframe_points.foreach_set("co", co.ravel())
            for kp in fc.keyframe_points:
                kp.interpolation = "LINEAR"
            fc.update()
    return action, end


def make_rig(glb, fps, name, context, coll, root, obj=None):
    """The wind rig: an armature object (``obj``, a rig built before, or a new one) with
    one bone per glTF joint (head at the joint's rest position), the clip as its action,
    and the scene's frame range and rate set to the clip. An ``obj`` whose bones are
    already the joints keeps its armature data. Returns ``(armature object, joint
    names)``, or ``(None, [])`` when the tree has no skin."""
    if not glb.doc.get("skins"):
        return None, []
    joints, names, heads, parents = _joints(glb)
    if obj is None:
        obj = bpy.data.objects.new(f"{name}_rig", bpy.data.armatures.new(f"{name}_rig"))
        obj["sylva_rig"] = 1
        obj.parent = root
        coll.objects.link(obj)
        _make_armature(f"{name}_rig", names, heads, parents, context, obj)
    elif not _same_bones(obj.data, names, heads, parents):
        _make_armature(f"{name}_rig", names, heads, parents, context, obj)
    action, end = _make_action(glb, fps, f"{name}_wind", set(joints))
    previous = obj.animation_data.action if obj.animation_data else None
    if action is not None:
        obj.animation_data_create().action = action
        scene = context.scene
        scene.render.fps = fps
        scene.render.fps_base = 1.0
        scene.frame_start = 1
        scene.frame_end = max(1, int(round(end * fps)))
    elif obj.animation_data:
        obj.animation_data.action = None
    if previous is not None and previous.users == 0:
        bpy.data.actions.remove(previous)
        if action is not None:
            action.name = f"{name}_wind"
    return obj, names


def _bind(obj, rig, names, skin):
    """Vertex groups from the glTF joints and weights, and the Armature modifier
    ``wind`` (added once; an object's other modifiers are left alone)."""
    joints, weights = skin
    if weights.dtype.kind in "iu":  # normalized integers
        weights = weights / np.float32(np.iinfo(weights.dtype).max)
    weights = weights.astype(np.float32)
    groups = [obj.vertex_groups.new(name=n) for n in names]
    vert = np.repeat(np.arange(len(joints)), joints.shape[1])
    j, w = joints.ravel().astype(np.int64), weights.ravel()
    keep = w > 0
    vert, j, w = vert[keep], j[keep], w[keep]
    # One vertex_groups.add call per distinct (joint, weight): sort by the pair packed
    # into one integer (the joint above the weight's bits) and cut the runs.
    key = (j << 32) | w.view(np.uint32).astype(np.int64)
    order = np.argsort(key, kind="stable")
    key = key[order]
    cuts = np.concatenate([[0], np.flatnonzero(key[1:] != key[:-1]) + 1, [len(key)]])
    for start, stop in zip(cuts[:-1].tolist(), cuts[1:].tolist()):
        joint = int(key[start] >> 32)
        weight = float(np.array([key[start] & 0xFFFFFFFF], dtype=np.uint32).view(np.float32)[0])
        groups[joint].add(vert[order[start:stop]].tolist(), weight, "REPLACE")
    mod = obj.modifiers.get("wind")
    if mod is None or mod.type != "ARMATURE":
        mod = obj.modifiers.new("wind", "ARMATURE")
    mod.object = rig


def _unbind(obj):
    """Removes the Armature modifier ``wind`` that ``_bind`` added."""
    mod = obj.modifiers.get("wind")
    if mod is not None and mod.type == "ARMATURE":
        obj.modifiers.remove(mod)


def _material_images(mat):
    return {n.image for n in mat.node_tree.nodes if n.type == "TEX_IMAGE" and n.image}


def _remove_orphans(meshes=(), materials=(), armatures=(), actions=()):
    """Removes those of the given data blocks no one uses any more (and then the images
    of the removed materials no one uses)."""
    for me in meshes:
        if me.users == 0:
            bpy.data.meshes.remove(me)
    for arm in armatures:
        if arm.users == 0:
            bpy.data.armatures.remove(arm)
    for action in actions:
        if action.users == 0:
            bpy.data.actions.remove(action)
    images = set()
    for mat in materials:
        if mat.users == 0:
            images.update(_material_images(mat))
            bpy.data.materials.remove(mat)
    for img in images:
        if img.users == 0:
            bpy.data.images.remove(img)


def _lod_collections(root):
    """``{k: collection}``: the LOD collections of the tree of ``root`` (those holding
    its objects, and empty ones beside it)."""
    beside = {c for parent in root.users_collection for c in parent.children}
    found = {}
    for coll in bpy.data.collections:
        if "sylva_lod_of" not in coll:
            continue
        objects = coll.objects
        if any(o.parent == root for o in objects) or (not objects and coll in beside):
            found.setdefault(int(coll["sylva_lod_of"]), coll)
    return found


def clear(root):
    """Removes what ``build`` made under ``root`` (its LOD collections, objects,
    meshes, rig, wind action, and the materials and images no one else uses); keeps
    ``root`` itself."""
    meshes, materials, armatures, actions = set(), set(), set(), set()
    for obj in list(root.children):
        if "sylva_rig" in obj:
            armatures.add(obj.data)
            if obj.animation_data and obj.animation_data.action:
                actions.add(obj.animation_data.action)
            bpy.data.objects.remove(obj)
    for coll in _lod_collections(root).values():
        for obj in list(coll.objects):
            if obj.type == "MESH":
                meshes.add(obj.data)
                materials.update(s.material for s in obj.material_slots if s.material)
            bpy.data.objects.remove(obj)
        bpy.data.collections.remove(coll)
    _remove_orphans(meshes, materials, armatures, actions)


def _digest(array):
    return hashlib.blake2b(np.ascontiguousarray(array).tobytes(), digest_size=16).hexdigest()


class Prepared:
    """What ``build`` needs from a grown tree, computed without touching Blender's data,
    so that live mode makes it in its worker thread: the recipe's TOML and seed, every
    LOD level's arrays, the glTF (levels past 0 and the wind rig, when the recipe has
    them) and each part's material and images, with a hash of the pixels so that a
    re-build keeps the images that did not change."""

    def __init__(self, tree):
        recipe = tree.recipe
        self.name = recipe.name or "sylva"
        self.toml = recipe.to_toml()
        self.seed = int(tree.seed)
        self.triangles = int(tree.triangles)
        self.fps = int(recipe.get("wind.fps") or 30)
        self.glb = Glb(tree.to_glb()) if needs_glb(recipe) else None
        parts = tree.parts  # each access copies the arrays: once
        instances = tree.instances
        self.levels = lod_levels(parts, self.glb, instances)
        self.looks = {}  # part name -> (material, {role: (pixels, hash)})
        for part in [*parts, *(p for p, _ in instances)]:
            if part.name not in self.looks:
                images = {role: (arr, _digest(arr)) for role, arr in part.images.items()}
                self.looks[part.name] = (part.material, images)


def _part_name(obj, k):
    if "sylva_part" in obj:
        return obj["sylva_part"]
    return obj.name.split(f"_LOD{k}_", 1)[-1]


def build(tree, context, root=None):
    """Builds ``tree`` (a ``sylva.Tree`` or a ``Prepared``) into the scene and returns
    its root Empty. The recipe's TOML and the seed are stored on the root.

    With ``root`` (a tree built before) the tree is replaced in place: each mesh object
    of a (LOD level, part) the new tree has too is kept — its name, transform,
    selection, visibility and modifiers — and gets the new mesh data; the rig object is
    kept (its armature data too when the bones did not change) and gets the new action;
    materials and images whose inputs did not change are kept. What the new tree lacks
    is removed, and the data blocks no longer used (old meshes, materials, images,
    armatures, actions) are removed too."""
    prep = tree if isinstance(tree, Prepared) else Prepared(tree)
    if root is None:
        coll = bpy.data.collections.new(prep.name)
        context.scene.collection.children.link(coll)
        root = bpy.data.objects.new(prep.name, None)
        root.empty_display_type = "PLAIN_AXES"
        coll.objects.link(root)
    else:
        coll = root.users_collection[0]
    root[RECIPE_PROP] = prep.toml
    root[SEED_PROP] = prep.seed
    lods = _lod_collections(root)
    old_objects = {}
    old_rig = None
    for obj in root.children:
        if "sylva_rig" in obj:
            old_rig = obj
        elif "sylva_lod" in obj and obj.type == "MESH":
            k = int(obj["sylva_lod"])
            old_objects[(k, _part_name(obj, k))] = obj
    old_meshes = {o.data for o in old_objects.values()}
    old_materials = {s.material for o in old_objects.values() for s in o.material_slots}
    old_materials.discard(None)
    renames = []

    # The rig (or none), kept in place where there was one.
    old_arm = old_rig.data if old_rig is not None else None
    has_skin = prep.glb is not None and bool(prep.glb.doc.get("skins"))
    rig, joint_names = None, []
    if has_skin:
        rig, joint_names = make_rig(prep.glb, prep.fps, root.name, context, coll, root, old_rig)
    elif old_rig is not None:
        action = old_rig.animation_data.action if old_rig.animation_data else None
        bpy.data.objects.remove(old_rig)
        _remove_orphans(armatures=[old_arm], actions=[action] if action else [])

    # Materials and images: kept where their inputs did not change.
    by_key = {m.get("sylva_key"): m for m in old_materials if m.get("sylva_key")}
    old_images = {}
    for mat in old_materials:
        for img in _material_images(mat):
            if "sylva_hash" in img:
                non_color = img.colorspace_settings.name == "Non-Color"
                old_images[(img["sylva_hash"], non_color)] = img
    materials = {}
    for part_name, (material, images) in prep.looks.items():
        key = json.dumps(
            [material, sorted((role, h) for role, (_, h) in images.items())], sort_keys=True
        )
        want = f"{root.name}_{material['name']}"
        mat = by_key.get(key)
        if mat is None:
            made = {}
            for role, (arr, h) in images.items():
                non_color = role != "base_color"
                img = old_images.get((h, non_color))
                if img is None:
                    img = make_image(f"{root.name}_{part_name}_{role}", arr, non_color)
                    img["sylva_hash"] = h
                    renames.append((bpy.data.images, img, f"{root.name}_{part_name}_{role}"))
                made[role] = img
            mat = make_material(want, material, made)
            mat["sylva_key"] = key
            renames.append((bpy.data.materials, mat, want))
            by_key[key] = mat
        materials[part_name] = mat

    # The LOD levels: mesh objects kept, their data replaced.
    for k, level in enumerate(prep.levels):
        lod = lods.pop(k, None)
        if lod is None:
            lod = bpy.data.collections.new(f"{root.name} LOD{k}")
            lod["sylva_lod_of"] = k
            coll.children.link(lod)
            if k > 0:
                lod.hide_viewport = True
                lod.hide_render = True
        for part_name, vertices, faces, normals, uvs, skin in level.parts:
            want = f"{root.name}_LOD{k}_{part_name}"
            me = make_mesh(want, vertices, faces, normals, uvs)
            if part_name in materials:
                me.materials.append(materials[part_name])
            obj = old_objects.pop((k, part_name), None)
            if obj is None:
                obj = bpy.data.objects.new(want, me)
                obj.parent = root
                obj["sylva_lod"] = k
                obj["sylva_part"] = part_name
                lod.objects.link(obj)
                if k > 0:
                    obj.hide_viewport = True
                    obj.hide_render = True
            else:
                obj.data = me
            renames.append((bpy.data.meshes, me, want))
            if rig is not None and skin is not None:
                _bind(obj, rig, joint_names, skin)
            else:
                _unbind(obj)

    # What the new tree lacks, and the data no one uses any more.
    for obj in old_objects.values():
        bpy.data.objects.remove(obj)
    for lod in lods.values():
        if not lod.objects:
            bpy.data.collections.remove(lod)
    _remove_orphans(old_meshes, old_materials)
    for blocks, block, want in renames:
        if block.name != want and blocks.get(want) is None:
            block.name = want
    return root


def tree_root(obj):
    """The root Empty of the sylva tree that ``obj`` belongs to, or None."""
    while obj is not None:
        if RECIPE_PROP in obj:
            return obj
        obj = obj.parent
    return None
