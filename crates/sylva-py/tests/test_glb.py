"""`Tree.parts` are the arrays the `.glb` holds: per part the same vertex and triangle
counts, positions within 1e-6, the same triangles, normals and UVs (issue 42)."""

import numpy as np
import pytest

import sylva
from conftest import Glb


def check_part(glb: Glb, part: sylva.Part) -> None:
    mesh = glb.mesh(part.name)
    (prim,) = mesh["primitives"]
    attrs = prim["attributes"]
    pos = glb.accessor(attrs["POSITION"])
    assert pos.shape == part.vertices.shape, part.name
    np.testing.assert_allclose(part.vertices, pos, rtol=0, atol=1e-6)
    idx = glb.accessor(prim["indices"]).reshape(-1, 3)
    assert idx.shape == part.faces.shape, part.name
    np.testing.assert_array_equal(part.faces, idx.astype(np.uint32))
    np.testing.assert_allclose(part.normals, glb.accessor(attrs["NORMAL"]), rtol=0, atol=1e-6)
    if part.uvs is None:
        assert "TEXCOORD_0" not in attrs
    else:
        np.testing.assert_allclose(part.uvs, glb.accessor(attrs["TEXCOORD_0"]), rtol=0, atol=1e-6)


def test_aspen_parts_equal_the_glb_accessors(aspen):
    glb = Glb(aspen.to_glb())
    parts = aspen.parts
    assert parts, "the aspen has parts"
    for part in parts:
        check_part(glb, part)
        assert part.vertices.dtype == np.float32 and part.faces.dtype == np.uint32
        assert part.faces.max() < len(part.vertices)
    for part, transforms in aspen.instances:
        check_part(glb, part)
        assert transforms.shape[1:] == (4, 4) and transforms.dtype == np.float32
    # Every triangle of the report is in a part or an instance.
    tris = sum(len(p.faces) for p in parts)
    tris += sum(len(p.faces) * len(t) for p, t in aspen.instances)
    assert tris == aspen.triangles


@pytest.mark.parametrize("preset", ["lsys-honda-a", "colonize-broadleaf"])
def test_other_presets_parts_equal_the_glb_accessors(preset):
    tree = sylva.Recipe.preset(preset).grow()
    glb = Glb(tree.to_glb())
    for part in tree.parts:
        check_part(glb, part)


def test_material_images_are_arrays(aspen):
    bark = next(p for p in aspen.parts if p.name == "bark")
    assert bark.material["name"] and len(bark.material["base_color"]) == 4
    img = bark.images["base_color"]
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] in (3, 4)
    assert img.std() > 0, "a drawn texture, not a flat colour"


def test_instanced_leaves_equal_the_glb_instances():
    tree = sylva.Recipe.preset("wp-quaking-aspen").set("leaves.mode", "instanced").grow()
    glb = Glb(tree.to_glb())
    ((part, transforms),) = tree.instances
    check_part(glb, part)
    mesh_index = next(i for i, m in enumerate(glb.doc["meshes"]) if m["name"] == part.name)
    (node,) = [n for n in glb.doc["nodes"] if n.get("mesh") == mesh_index]
    ext = node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]
    t, r, s = (glb.accessor(ext[k]) for k in ("TRANSLATION", "ROTATION", "SCALE"))
    assert len(t) == len(transforms)
    # An instance's world matrix is the node's transform after the instance's own.
    world = trs(node["translation"], node["rotation"], node["scale"]) @ trs(t, r, s)
    np.testing.assert_allclose(transforms, world, rtol=0, atol=1e-5)


def trs(t, r, s) -> np.ndarray:
    """glTF translation, rotation (quaternion x, y, z, w) and scale as 4×4 matrices."""
    t, r, s = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (t, r, s))
    x, y, z, w = r.T
    rot = np.stack(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)
    m = np.zeros((len(t), 4, 4))
    m[:, :3, :3] = rot * s[:, None, :]
    m[:, :3, 3] = t
    m[:, 3, 3] = 1
    return m
