"""Helpers of the sylva Python tests: the repository root, a GLB reader (its JSON and
accessors, parsed here so the tests need no glTF library) and the Khronos glTF
validator (tools/gltf-validator, run by Node)."""

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
VALIDATOR = ROOT / "tools" / "gltf-validator"

_COMPONENTS = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Glb:
    """A parsed .glb: ``doc`` (the JSON) and ``accessor(i)`` (an accessor as an array)."""

    def __init__(self, data: bytes):
        magic, version, total = struct.unpack_from("<4sII", data, 0)
        assert magic == b"glTF" and version == 2 and total == len(data)
        json_len, json_type = struct.unpack_from("<II", data, 12)
        assert json_type == 0x4E4F534A
        self.doc = json.loads(data[20 : 20 + json_len])
        at = 20 + json_len
        bin_len, bin_type = struct.unpack_from("<II", data, at)
        assert bin_type == 0x004E4942
        self.bin = data[at + 8 : at + 8 + bin_len]

    def accessor(self, index: int) -> np.ndarray:
        acc = self.doc["accessors"][index]
        view = self.doc["bufferViews"][acc["bufferView"]]
        dtype = np.dtype(_COMPONENTS[acc["componentType"]])
        width = _WIDTHS[acc["type"]]
        stride = view.get("byteStride", dtype.itemsize * width)
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        count = acc["count"]
        strides = (stride, dtype.itemsize)
        rows = np.ndarray((count, width), dtype, self.bin, start, strides)
        return rows.copy() if width > 1 else rows[:, 0].copy()

    def mesh(self, name: str) -> dict:
        """The one mesh called ``name``."""
        found = [m for m in self.doc["meshes"] if m.get("name") == name]
        assert len(found) == 1, f"meshes called {name}: {len(found)}"
        return found[0]


def require(var: str) -> bool:
    """Whether CI requires the check that ``var`` names (else it may be skipped)."""
    return os.environ.get(var) == "1"


def validate_gltf(paths) -> None:
    """Runs the Khronos glTF validator on ``paths``; fails on any error or warning.
    Skipped when Node or the npm package is missing, unless
    SYLVA_REQUIRE_GLTF_VALIDATOR=1 (CI)."""
    node = shutil.which("node")
    if node is None or not (VALIDATOR / "node_modules" / "gltf-validator").is_dir():
        msg = "glTF validator missing: run `npm ci --prefix tools/gltf-validator`"
        if require("SYLVA_REQUIRE_GLTF_VALIDATOR"):
            pytest.fail(msg)
        pytest.skip(msg)
    out = subprocess.run(
        [node, str(VALIDATOR / "validate.mjs"), *map(str, paths)], capture_output=True, text=True
    )
    assert out.returncode == 0, f"glTF validation failed:\n{out.stdout}{out.stderr}"


@pytest.fixture(scope="session")
def aspen():
    """The aspen preset, grown once."""
    import sylva

    return sylva.Recipe.preset("wp-quaking-aspen").grow()
