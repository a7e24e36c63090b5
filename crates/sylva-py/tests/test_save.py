"""`Tree.save` writes every format the CLI writes, and the glTF files pass the Khronos
validator."""

import json

import pytest

import sylva
from conftest import validate_gltf

MAGIC = {
    "glb": b"glTF",
    "gltf": b"{",
    "obj": b"#",
    "ply": b"ply",
    "pov": b"//",
    "png": b"\x89PNG",
}


@pytest.mark.parametrize("ext", ["glb", "gltf", "obj", "ply", "pov", "lst", "json", "png"])
def test_save_every_format(tmp_path, ext):
    tree = sylva.Recipe.preset("lsys-honda-a").set("output.preview_size", 64).grow()
    path = tmp_path / f"tree.{ext}"
    tree.save(path)
    data = path.read_bytes()
    assert len(data) > 0
    if ext in MAGIC:
        assert data.startswith(MAGIC[ext]), data[:16]
    if ext == "json":
        assert json.loads(data)
    if ext == "lst":
        assert data.decode().strip()
    if ext == "obj":
        assert (tmp_path / "tree.mtl").exists()
    if ext in ("glb", "gltf"):
        validate_gltf([path])


def test_save_accepts_str_paths(tmp_path):
    tree = sylva.Recipe.preset("lsys-honda-a").grow()
    tree.save(str(tmp_path / "a.glb"))
    assert (tmp_path / "a.glb").read_bytes() == tree.to_glb()


def test_a_bad_path_is_an_error_and_writes_nothing(tmp_path):
    tree = sylva.Recipe.preset("lsys-honda-a").grow()
    with pytest.raises(sylva.SylvaError, match="extension"):
        tree.save(tmp_path / "tree.xyz")
    with pytest.raises(sylva.SylvaError):
        tree.save(tmp_path / "no" / "such" / "folder" / "tree.glb")
    assert list(tmp_path.iterdir()) == []
