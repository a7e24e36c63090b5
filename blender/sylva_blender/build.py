"""Builds native Blender data from a grown ``sylva.Tree``: one mesh object per part and
LOD level (vertices, faces, normals and UVs copied with ``foreach_set``, smooth shading
with the engine's normals as custom split normals), Principled BSDF materials wired to
the part's images and shared by every LOD level, and an Empty that holds the recipe.

Coordinates: sylva is +Y up (as glTF); Blender is +Z up, so (x, y, z) becomes
(x, -z, y), the conversion Blender's glTF importer makes. UVs have glTF's top-left
origin and are flipped to Blender's bottom-left one.

LOD0 is ``tree.parts``. The Python API exposes no other level, so levels 1.. are read
from the tree's own binary glTF (``tree.to_glb()``, nodes ``sylva_LOD<k>``), parsed in
memory here: no file and no glTF importer."""

import json
import re
import struct

import bpy
import numpy as np

RECIPE_PROP = "sylva_recipe"
SEED_PROP = "sylva_seed"

_COMPONENTS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


class Level:
    """One LOD level: a list of ``(part name, vertices, faces, normals, uvs)``."""

    def __init__(self, parts):
        self.parts = parts


def _accessor(doc, binary, index):
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(_COMPONENTS[acc["componentType"]])
    width = _WIDTHS[acc["type"]]
    stride = view.get("byteStride", dtype.itemsize * width)
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    rows = np.ndarray((acc["count"], width), dtype, binary, start, (stride, dtype.itemsize))
    return rows.copy() if width > 1 else rows[:, 0].copy()


def lod_levels(tree):
    """The tree's levels: LOD0 from ``tree.parts``, the others from its glTF."""
    levels = [Level([(p.name, p.vertices, p.faces, p.normals, p.uvs) for p in tree.parts])]
    if not tree.recipe.get("lod.levels"):
        return levels
    data = tree.to_glb()
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + json_len])
    binary = data[28 + json_len :]
    names = [p[0] for p in levels[0].parts]
    found = {}
    for node in doc["nodes"]:
        m = re.fullmatch(r"sylva_LOD(\d+)", node.get("name", ""))
        if m and int(m.group(1)) > 0 and "mesh" in node:
            found[int(m.group(1))] = doc["meshes"][node["mesh"]]
    for k in sorted(found):
        parts = []
        for j, prim in enumerate(found[k]["primitives"]):
            attrs = prim["attributes"]
            faces = _accessor(doc, binary, prim["indices"]).astype(np.uint32).reshape(-1, 3)
            uvs = _accessor(doc, binary, attrs["TEXCOORD_0"]) if "TEXCOORD_0" in attrs else None
            parts.append(
                (
                    names[j] if j < len(names) else f"part{j}",
                    _accessor(doc, binary, attrs["POSITION"]),
                    faces,
                    _accessor(doc, binary, attrs["NORMAL"]),
                    uvs,
                )
            )
        levels.append(Level(parts))
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
    """A Blender image (packed into the .blend) from an (H, W, C) uint8 array."""
    h, w, c = array.shape
    img = bpy.data.images.new(name, w, h, alpha=(c == 4))
    px = np.ones((h, w, 4), dtype=np.float32)
    px[:, :, :c] = array[::-1] / np.float32(255.0)
    img.pixels.foreach_set(px.ravel())
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    img.pack()
    return img


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
        sep = nt.nodes.new("ShaderNodeSeparateRGB")
        sep.location = (x, 0)
        nt.links.new(tex.outputs["Color"], sep.inputs[0])
        nt.links.new(sep.outputs[1], bsdf.inputs["Roughness"])
        nt.links.new(sep.outputs[2], bsdf.inputs["Metallic"])
    return mat


def clear(root):
    """Removes what ``build`` made under ``root`` (its LOD collections, objects,
    meshes, and the materials and images no one else uses); keeps ``root`` itself."""
    meshes, materials = set(), set()
    for coll in list(root.users_collection[0].children) if root.users_collection else []:
        if "sylva_lod_of" not in coll:
            continue
        for obj in list(coll.objects):
            if obj.type == "MESH":
                meshes.add(obj.data)
                materials.update(s.material for s in obj.material_slots if s.material)
            bpy.data.objects.remove(obj)
        bpy.data.collections.remove(coll)
    for me in meshes:
        if me.users == 0:
            bpy.data.meshes.remove(me)
    images = set()
    for mat in materials:
        if mat.users == 0:
            images.update(n.image for n in mat.node_tree.nodes if n.type == "TEX_IMAGE" and n.image)
            bpy.data.materials.remove(mat)
    for img in images:
        if img.users == 0:
            bpy.data.images.remove(img)


def build(tree, context, root=None):
    """Builds ``tree`` into the scene and returns its root Empty. With ``root`` (a tree
    built before), its contents are replaced and its transform, name and selection are
    kept. The recipe's TOML and the seed are stored on the root."""
    recipe = tree.recipe
    name = recipe.name or "sylva"
    levels = lod_levels(tree)
    if root is None:
        coll = bpy.data.collections.new(name)
        context.scene.collection.children.link(coll)
        root = bpy.data.objects.new(name, None)
        root.empty_display_type = "PLAIN_AXES"
        coll.objects.link(root)
    else:
        clear(root)
        coll = root.users_collection[0]
    root[RECIPE_PROP] = recipe.to_toml()
    root[SEED_PROP] = int(tree.seed)
    materials = {}
    for part in tree.parts:
        roles = part.images
        images = {
            role: make_image(f"{root.name}_{part.name}_{role}", arr, role != "base_color")
            for role, arr in roles.items()
        }
        materials[part.name] = make_material(
            f"{root.name}_{part.material['name']}", part.material, images
        )
    for k, level in enumerate(levels):
        lod = bpy.data.collections.new(f"{root.name} LOD{k}")
        lod["sylva_lod_of"] = k
        coll.children.link(lod)
        for part_name, vertices, faces, normals, uvs in level.parts:
            me = make_mesh(f"{root.name}_LOD{k}_{part_name}", vertices, faces, normals, uvs)
            if part_name in materials:
                me.materials.append(materials[part_name])
            obj = bpy.data.objects.new(me.name, me)
            obj.parent = root
            obj["sylva_lod"] = k
            lod.objects.link(obj)
            if k > 0:
                obj.hide_viewport = True
                obj.hide_render = True
        if k > 0:
            lod.hide_viewport = True
            lod.hide_render = True
    return root


def tree_root(obj):
    """The root Empty of the sylva tree that ``obj`` belongs to, or None."""
    while obj is not None:
        if RECIPE_PROP in obj:
            return obj
        obj = obj.parent
    return None
