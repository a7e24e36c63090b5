"""Makes ``sylva_blender.zip``: the add-on package ``sylva_blender/`` with the sylva
wheel in ``sylva_blender/wheels/`` and the manifest's ``wheels`` naming it (a path
relative to the manifest) and ``platforms`` its platform, installable by Blender 3.4+
(Preferences > Add-ons > Install) and 4.2+ (as an extension). The manifest written is
checked against Blender's extension manifest schema 1.0.0 (``check_manifest``) and
the zip is not written if it breaks it.

    python3 blender/build_zip.py [--wheel WHEEL] [--out blender/sylva_blender.zip]

The wheel defaults to SYLVA_WHEEL, else the newest ``target/wheels/sylva-*abi3*.whl``
(``maturin build --release -m crates/sylva-py/Cargo.toml`` makes it)."""

import argparse
import os
import posixpath
import re
import sys
import zipfile
from pathlib import Path

try:
    import tomllib
except ImportError:  # Python < 3.11: the manifest is written but not checked
    tomllib = None

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PACKAGE = HERE / "sylva_blender"


def find_wheel():
    """SYLVA_WHEEL, else the newest abi3 wheel in target/wheels, else None."""
    if os.environ.get("SYLVA_WHEEL"):
        return Path(os.environ["SYLVA_WHEEL"])
    wheels = sorted((ROOT / "target" / "wheels").glob("sylva-*abi3*.whl"), key=os.path.getmtime)
    return wheels[-1] if wheels else None


# Blender's extension manifest, schema 1.0.0 (developer.blender.org/docs/features/
# extensions/schema/1.0.0 and the manual's "How to Create Extensions" and "Python Wheels").
REQUIRED = (
    "schema_version",
    "id",
    "version",
    "name",
    "tagline",
    "maintainer",
    "type",
    "blender_version_min",
    "license",
)
PERMISSIONS = {"files", "network", "clipboard", "camera", "microphone"}
PLATFORMS = {"windows-x64", "windows-arm64", "macos-x64", "macos-arm64", "linux-x64", "linux-arm64"}
SEMVER = re.compile(r"^\d+\.\d+\.\d+(?:-[0-9A-Za-z.-]+)?(?:\+[0-9A-Za-z.-]+)?$")


class ManifestError(Exception):
    """A manifest that breaks the extension schema."""


def wheel_platforms(name):
    """Blender's platforms for a wheel file name's platform tag (``linux_x86_64`` and
    ``manylinux_2_28_x86_64``: ``linux-x64``; ``win_amd64``: ``windows-x64``;
    ``macosx_11_0_arm64``: ``macos-arm64``; ``universal2``: both macOS ones); None for
    ``any``."""
    tag = name[: -len(".whl")].split("-")[-1]
    if tag == "any":
        return None
    system = tag.split("_", 1)[0]
    if system.startswith(("manylinux", "musllinux", "linux")):
        system = "linux"
    elif system.startswith("win"):
        system = "windows"
    elif system.startswith("macosx"):
        system = "macos"
    machine = tag.rsplit("_", 1)[-1] if not tag.endswith("x86_64") else "x86_64"
    if machine == "universal2":
        return {f"{system}-x64", f"{system}-arm64"}
    arch = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}
    return {f"{system}-{arch.get(machine, machine)}"}


def _terse(value):
    """The schema's rule for a tagline and a permission's reason, or None."""
    if not isinstance(value, str) or not value.strip():
        return "a non-empty string expected"
    if value != value.strip():
        return "no leading or trailing white space expected"
    if len(value) > 64:
        return f"at most 64 characters expected, found {len(value)}"
    if not (value[-1].isalnum() or value[-1] in ")]}"):
        return "must not end with punctuation"
    return None


def check_manifest(text, files, where="blender_manifest.toml"):
    """The list of ways the manifest ``text`` breaks the extension schema 1.0.0, each
    naming the key and why; ``files`` are the archive's paths relative to the
    manifest's folder (every ``wheels`` path must be one). Empty when it is valid."""
    try:
        m = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        return [f"{where}: TOML error: {e}"]
    errors = [f"{where}: missing `{key}`" for key in REQUIRED if key not in m]

    def bad(key, why):
        errors.append(f"{where}: `{key}` {why}, found {m.get(key)!r}")

    if m.get("schema_version", "1.0.0") != "1.0.0":
        bad("schema_version", 'must be "1.0.0"')
    ident = m.get("id", "x")
    if not (
        isinstance(ident, str)
        and ident.isidentifier()
        and "__" not in ident
        and not ident.startswith("_")
        and not ident.endswith("_")
    ):
        bad("id", "must be a Python identifier without `__` or a leading or trailing `_`")
    if not SEMVER.match(str(m.get("version", "0.0.0"))):
        bad("version", "must be a semantic version")
    for key in ("name", "maintainer"):
        value = m.get(key, "x")
        if not isinstance(value, str) or not value.strip() or value != value.strip():
            bad(key, "must be a non-empty string without surrounding white space")
    if "tagline" in m and (why := _terse(m["tagline"])):
        bad("tagline", why)
    if m.get("type", "add-on") not in ("add-on", "theme"):
        bad("type", 'must be "add-on" or "theme"')
    version_min = str(m.get("blender_version_min", "4.2.0"))
    parts = version_min.split(".")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        bad("blender_version_min", "must be three numbers separated by `.`")
    elif tuple(int(p) for p in parts) < (4, 2, 0):
        bad("blender_version_min", "must be 4.2.0 or later (extensions start there)")
    licenses = m.get("license", ["SPDX:MIT"])
    if not (isinstance(licenses, list) and licenses) or not all(
        isinstance(x, str) and x.startswith("SPDX:") and len(x) > 5 for x in licenses
    ):
        bad("license", 'must be a non-empty list of "SPDX:<identifier>"')
    permissions = m.get("permissions", {})
    if not isinstance(permissions, dict):
        bad("permissions", "must be a table of reasons")
    else:
        for key, reason in permissions.items():
            if key not in PERMISSIONS:
                bad("permissions", f"has `{key}`, not one of {sorted(PERMISSIONS)}")
            elif why := _terse(reason):
                bad("permissions", f"`{key}`'s reason: {why}")
    platforms = m.get("platforms", sorted(PLATFORMS))
    if not (isinstance(platforms, list) and platforms and set(platforms) <= PLATFORMS):
        bad("platforms", f"must be a non-empty list of {sorted(PLATFORMS)}")
        platforms = sorted(PLATFORMS)
    wheels = m.get("wheels", [])
    if not isinstance(wheels, list):
        bad("wheels", "must be a list of paths")
        wheels = []
    for path in wheels:
        name = posixpath.basename(str(path))
        if not isinstance(path, str) or "\\" in path or '"' in path:
            bad("wheels", f"path {path!r} must use forward slashes and no quotes")
        elif not name.endswith(".whl") or not 5 <= len(name.split("-")) <= 6:
            bad("wheels", f"{path!r} is not a wheel file name (name-version-py-abi-platform.whl)")
        elif posixpath.normpath(path) not in files:
            bad("wheels", f"{path!r} is not in the archive beside the manifest")
        elif (tags := wheel_platforms(name)) is not None and not tags & set(platforms):
            bad("wheels", f"{name}'s platform {sorted(tags)} is not in `platforms`")
    return errors


def build(wheel, out):
    """Writes the zip ``out`` with ``wheel`` bundled; returns ``out``. Raises
    ManifestError (nothing written) when the manifest breaks the extension schema."""
    wheel, out = Path(wheel), Path(out)
    if not wheel.is_file():
        raise FileNotFoundError(f"wheel {wheel} does not exist")
    manifest = (PACKAGE / "blender_manifest.toml").read_text()
    platforms = sorted(wheel_platforms(wheel.name) or ())
    manifest = re.sub(r"(?m)^wheels = .*$", f'wheels = ["./wheels/{wheel.name}"]', manifest)
    if platforms:
        listed = ", ".join(f'"{p}"' for p in platforms)
        manifest = re.sub(r"(?m)^platforms = .*$", f"platforms = [{listed}]", manifest)
    files = {
        p.relative_to(PACKAGE).as_posix()
        for p in PACKAGE.rglob("*")
        if p.is_file() and p.relative_to(PACKAGE).parts[0] not in ("_site", "wheels")
    } | {f"wheels/{wheel.name}"}
    if tomllib is not None and (errors := check_manifest(manifest, files)):
        raise ManifestError("; ".join(errors))
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(PACKAGE.rglob("*")):
            rel = path.relative_to(PACKAGE)
            if path.is_dir() or "__pycache__" in rel.parts or rel.parts[0] in ("_site", "wheels"):
                continue
            arc = f"sylva_blender/{rel.as_posix()}"
            if rel.name == "blender_manifest.toml":
                zf.writestr(arc, manifest)
            else:
                zf.write(path, arc)
        zf.write(wheel, f"sylva_blender/wheels/{wheel.name}", zipfile.ZIP_STORED)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--wheel", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=HERE / "sylva_blender.zip")
    args = ap.parse_args()
    wheel = args.wheel or find_wheel()
    if wheel is None:
        sys.exit(
            "build_zip: no wheel: set SYLVA_WHEEL, pass --wheel, or run "
            "`maturin build --release -m crates/sylva-py/Cargo.toml`"
        )
    try:
        print(build(wheel, args.out))
    except (OSError, ManifestError) as e:
        sys.exit(f"build_zip: {e}")


if __name__ == "__main__":
    main()
