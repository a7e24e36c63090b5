"""The wheel `maturin build --release` makes installs into a clean virtual environment
that has only numpy, and the one-liner of issue 42 writes a GLB the Khronos validator
passes.

The wheel is SYLVA_WHEEL's when that is set (.ci/run builds the wheel once and installs
it for the other tests too); otherwise this test builds one, which needs maturin
(skipped without it unless SYLVA_REQUIRE_WHEEL=1). PyPI is needed for numpy. The build
reuses the workspace's target/release, so after `pip install ./crates/sylva-py` it only
repackages."""

import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from conftest import ROOT, require, validate_gltf

ONE_LINER = "import sylva; sylva.Recipe.preset('wp-quaking-aspen').grow().save('a.glb')"


def maturin():
    here = str(Path(sys.executable).parent)
    found = shutil.which("maturin") or shutil.which("maturin", path=here)
    if found is None:
        msg = "maturin is not installed (pip install maturin)"
        if require("SYLVA_REQUIRE_WHEEL"):
            pytest.fail(msg)
        pytest.skip(msg)
    return found


def run(args, **kw):
    out = subprocess.run([str(a) for a in args], capture_output=True, text=True, **kw)
    assert out.returncode == 0, f"{' '.join(map(str, args))}:\n{out.stdout}\n{out.stderr}"
    return out.stdout


def test_wheel_installs_with_only_numpy_and_writes_a_valid_glb(tmp_path):
    if os.environ.get("SYLVA_WHEEL"):
        wheel = Path(os.environ["SYLVA_WHEEL"])
        assert wheel.is_file() and wheel.name.startswith("sylva-"), f"SYLVA_WHEEL={wheel}"
    else:
        wheels = tmp_path / "wheels"
        manifest = ROOT / "crates/sylva-py/Cargo.toml"
        run([maturin(), "build", "--release", "-m", manifest, "--out", wheels], cwd=ROOT)
        (wheel,) = wheels.glob("sylva-*.whl")
    assert "abi3" in wheel.name, wheel.name
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True, clear=True).create(env_dir)
    py = env_dir / "bin" / "python"
    run([py, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "numpy"])
    run([py, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps", wheel])
    installed = run([py, "-m", "pip", "list", "--format=freeze", "--disable-pip-version-check"])
    names = {line.split("==")[0].lower() for line in installed.split()}
    assert names - {"pip", "setuptools", "wheel"} == {"numpy", "sylva"}, installed
    work = tmp_path / "work"
    work.mkdir()
    run([py, "-c", ONE_LINER], cwd=work)
    glb = work / "a.glb"
    assert glb.read_bytes()[:4] == b"glTF"
    validate_gltf([glb])
