"""The Blender add-on (blender/sylva_blender, issue 43) in Debian's Blender, headless.

`blender -b --factory-startup` runs blender/tests/addon_check.py: it installs the add-on
from the zip blender/build_zip.py makes (the wheel bundled), enables it, grows an
L-system, a Weber-Penn (with LOD levels and wind) and a space-colonization preset
through `bpy.ops.sylva.grow`, renders the last at 128 x 128 (Cycles, CPU), and checks
object, material and image counts, vertex and triangle counts against the Python API,
that only LOD0 is visible, the bark's Base Color image, the wind rig (bones as the
recipe's joints, one action, the scene's frame range the clip's, the deformed bark
equal to the glTF skin's at a key), instanced leaves, re-growing in place, the panel's
schema settings (the generator's too), Export, and that bad settings cancel with an
error report and leave the tree. Then Live mode on the aspen: a leaf setting and a
generator setting changed through the panel's properties each regrow it in place
within 2 s (timed, `live.pump` standing in for Blender's timer, which does not fire in
a headless script), keeping its objects, transform, modifiers and selection; a change
while a regrow runs drops the stale result; a bad value is a panel error and leaves
the tree. Blender's user folders are temporary, so nothing is installed for the user.

Skipped when `blender` is missing, unless SYLVA_REQUIRE_BLENDER=1 (.ci/run). The wheel is
SYLVA_WHEEL's (.ci/run builds it) or the newest in target/wheels (`maturin build
--release -m crates/sylva-py/Cargo.toml`; rebuild it after changing the bindings);
without one the test is skipped. The settings parser is also tested here without
Blender."""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import ROOT, require

BLENDER_DIR = ROOT / "blender"
sys.path.insert(0, str(BLENDER_DIR))

from sylva_blender import settings  # noqa: E402  (the add-on's folder, put on sys.path)


def _wheel():
    if os.environ.get("SYLVA_WHEEL"):
        wheel = Path(os.environ["SYLVA_WHEEL"])
        assert wheel.is_file(), f"SYLVA_WHEEL={wheel} does not exist"
        return wheel
    found = sorted((ROOT / "target" / "wheels").glob("sylva-*abi3*.whl"), key=os.path.getmtime)
    if not found:
        pytest.skip("no sylva wheel: set SYLVA_WHEEL or run maturin build --release")
    return found[-1]


def _blender():
    found = shutil.which("blender")
    if found is None:
        msg = "blender is not installed (apt-get install blender python3-numpy)"
        if require("SYLVA_REQUIRE_BLENDER"):
            pytest.fail(msg)
        pytest.skip(msg)
    return found


def test_addon_grows_native_trees_in_blender(tmp_path):
    blender = _blender()
    wheel = _wheel()
    zip_path = tmp_path / "sylva_blender.zip"
    out = subprocess.run(
        [sys.executable, str(BLENDER_DIR / "build_zip.py"), "--wheel", str(wheel)]
        + ["--out", str(zip_path)],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    env = dict(os.environ)
    env["BLENDER_USER_SCRIPTS"] = str(tmp_path / "scripts")
    env["BLENDER_USER_CONFIG"] = str(tmp_path / "config")
    result_path = tmp_path / "result.json"
    script = BLENDER_DIR / "tests" / "addon_check.py"
    args = [blender, "-b", "--factory-startup", "--python-exit-code", "1"]
    args += ["--python", str(script), "--", str(zip_path), str(result_path)]
    t0 = time.perf_counter()
    run = subprocess.run(args, capture_output=True, text=True, env=env, timeout=300)
    seconds = time.perf_counter() - t0
    log = run.stdout + run.stderr
    assert run.returncode == 0 and "addon_check: ok" in run.stdout, log[-6000:]
    # Errors are Blender reports; no Python traceback reaches the console.
    assert "Traceback" not in log, log[-6000:]
    result = json.loads(result_path.read_text())
    # The package came from the bundled wheel, extracted into the installed add-on.
    assert "/_site/sylva/" in result["sylva_file"], result["sylva_file"]
    aspen = result["wp-quaking-aspen"]
    assert (aspen["objects"], aspen["materials"], aspen["images"]) == (4, 2, 4), aspen
    assert len(aspen["lod_triangles"]) == 2 and aspen["lod_triangles"][1] <= 5000, aspen
    wind = result["wind"]  # the rig: bones, the clip as one action, the frame range
    assert wind["bones"] > 0 and wind["actions"] == 1 and wind["frames"] == 120, wind
    # Blender's Armature deformation equals the glTF skin's at a key of the clip.
    assert wind["err_m"] < 1e-3 and wind["sway_m"] > 1e-3, wind
    honda = result["lsys-honda-a"]
    assert (honda["objects"], honda["materials"], honda["images"]) == (1, 1, 3), honda
    # Instanced leaves (leaves.mode = "instanced") are realized into one mesh.
    assert result["instanced_leaves"]["instances"] > 100, result["instanced_leaves"]
    colonize = result["colonize-broadleaf"]
    assert (colonize["objects"], colonize["materials"], colonize["images"]) == (2, 2, 4), colonize
    # The 128 x 128 Cycles render of the colonization tree shows a tree: some pixels, not all.
    assert 0.02 < result["render"]["covered"] < 0.9, result["render"]
    assert len(result["errors"]) == 6, result["errors"]
    assert result["panel_keys"] >= 30, result["panel_keys"]
    live = result["live"]  # seconds from the panel change to the mesh replaced
    assert live["leaf"]["seconds"] < 2.0 and live["generator"]["seconds"] < 2.0, live
    assert "generate" not in live["leaf"]["stages"], live["leaf"]  # the session's reuse
    assert live["tree"]["triangles"] > 0 and live["wind"]["err_m"] < 1e-3, live
    assert len(live["errors"]) == 2 and all("unchanged" in e for e in live["errors"]), live
    grow_s = aspen["grow_and_build_s"]
    print(
        f"blender add-on check: {seconds:.1f} s; aspen grow+build {grow_s:.2f} s; live "
        f"leaf {live['leaf']['seconds']:.2f} s (worker {live['leaf']['grow_s']:.2f} s, build "
        f"{live['leaf']['build_s']:.2f} s), generator {live['generator']['seconds']:.2f} s "
        f"(worker {live['generator']['grow_s']:.2f} s, build {live['generator']['build_s']:.2f} s)"
    )


def test_settings_lines_and_toml_overlay():
    assert settings.parse("mesh.sides = 6\n# a comment\n\nwind.preset=breeze") == [
        ("mesh.sides", 6, "line 1 (`mesh.sides`)"),
        ("wind.preset", "breeze", "line 4 (`wind.preset`)"),
    ]
    assert settings.parse('lod.levels = [20000, 5000]\nleaves.mode = "cards"') == [
        ("lod.levels", [20000, 5000], "line 1 (`lod.levels`)"),
        ("leaves.mode", "cards", "line 2 (`leaves.mode`)"),
    ]
    if settings.tomllib is not None:
        overlay = "[mesh]\nsides = 5\n[wind]\npreset = 'calm'\n"
        assert settings.parse(overlay) == [
            ("mesh.sides", 5, "key `mesh.sides`"),
            ("wind.preset", "calm", "key `wind.preset`"),
        ]


def test_settings_errors_name_the_line_and_the_key():
    with pytest.raises(settings.SettingsError, match="line 2: expected key=value"):
        settings.parse("mesh.sides = 6\nmesh.sides")
    with pytest.raises(settings.SettingsError, match="line 1: no key"):
        settings.parse("= 6")
    import sylva

    recipe = sylva.Recipe.preset("lsys-honda-a")
    with pytest.raises(settings.SettingsError, match=r"line 1 \(`mesh.sides`\).*3..=1024"):
        settings.apply(sylva, recipe, settings.parse("mesh.sides = 2"))
    assert recipe.get("mesh.sides") == sylva.Recipe.preset("lsys-honda-a").get("mesh.sides")


def test_zip_manifest_follows_the_extension_schema(tmp_path):
    """The zip's blender_manifest.toml (Blender 4.2+ extensions, schema 1.0.0): every
    required key, `wheels` naming the bundled wheel by a path relative to the manifest
    that is in the zip, `platforms` the wheel's. (No Blender 4.2 here to install it.)"""
    tomllib = pytest.importorskip("tomllib")
    import zipfile

    import build_zip

    wheel = tmp_path / "sylva-0.1.0-cp39-abi3-win_amd64.whl"  # any platform's name
    wheel.write_bytes(b"PK\x05\x06" + bytes(18))  # an empty zip: only copied
    out = build_zip.build(wheel, tmp_path / "addon.zip")
    with zipfile.ZipFile(out) as zf:
        names = set(zf.namelist())
        text = zf.read("sylva_blender/blender_manifest.toml").decode()
    manifest = tomllib.loads(text)
    for key in build_zip.REQUIRED:
        assert key in manifest, key
    assert manifest["schema_version"] == "1.0.0" and manifest["type"] == "add-on"
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["wheels"] == [f"./wheels/{wheel.name}"]
    assert "sylva_blender/wheels/" + wheel.name in names  # beside the manifest
    assert manifest["platforms"] == ["windows-x64"]
    assert "sylva_blender/__init__.py" in names
    files = {n.split("/", 1)[1] for n in names}
    assert build_zip.check_manifest(text, files) == []


def test_manifest_check_names_what_breaks_the_schema():
    pytest.importorskip("tomllib")
    import build_zip

    base = (BLENDER_DIR / "sylva_blender" / "blender_manifest.toml").read_text()
    wheel = "sylva-0.1.0-cp39-abi3-linux_x86_64.whl"
    good = base.replace("wheels = []", f'wheels = ["./wheels/{wheel}"]')
    files = {f"wheels/{wheel}", "__init__.py"}
    assert build_zip.check_manifest(good, files) == []
    cases = [
        (good.replace('id = "sylva_blender"', 'id = "sylva-blender"'), "`id`"),
        (good.replace("as native objects", "as native objects."), "punctuation"),
        (good.replace('blender_version_min = "4.2.0"', 'blender_version_min = "3.4.0"'), "4.2.0"),
        (good.replace('files = "', 'disk = "'), "`disk`"),
        (good.replace('license = ["SPDX:MIT", ', "license = ["), None),  # still valid
        (good.replace('license = ["SPDX:MIT", "SPDX:Apache-2.0"]', 'license = ["MIT"]'), "SPDX"),
        (good.replace('platforms = ["linux-x64"]', 'platforms = ["macos-arm64"]'), "platform"),
        (good.replace('version = "0.1.0"', 'version = "0.1"'), "semantic"),
        (good.replace('maintainer = "sylva contributors"\n', ""), "missing `maintainer`"),
    ]
    for text, needle in cases:
        errors = build_zip.check_manifest(text, files)
        if needle is None:
            assert errors == [], errors
        else:
            assert len(errors) == 1 and needle in errors[0], (needle, errors)
    missing = build_zip.check_manifest(good, {"__init__.py"})
    assert len(missing) == 1 and "not in the archive" in missing[0], missing
    assert build_zip.wheel_platforms("a-1-cp39-abi3-manylinux_2_28_aarch64.whl") == {"linux-arm64"}
    assert build_zip.wheel_platforms("a-1-cp39-abi3-macosx_10_9_universal2.whl") == {
        "macos-x64",
        "macos-arm64",
    }
    assert build_zip.wheel_platforms("a-1-py3-none-any.whl") is None
