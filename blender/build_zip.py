"""Makes ``sylva_blender.zip``: the add-on package ``sylva_blender/`` with the sylva
wheel in ``sylva_blender/wheels/`` and the manifest's ``wheels`` naming it, installable
by Blender 3.4+ (Preferences > Add-ons > Install) and 4.2+ (as an extension).

    python3 blender/build_zip.py [--wheel WHEEL] [--out blender/sylva_blender.zip]

The wheel defaults to SYLVA_WHEEL, else the newest ``target/wheels/sylva-*abi3*.whl``
(``maturin build --release -m crates/sylva-py/Cargo.toml`` makes it)."""

import argparse
import os
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PACKAGE = HERE / "sylva_blender"


def find_wheel():
    """SYLVA_WHEEL, else the newest abi3 wheel in target/wheels, else None."""
    if os.environ.get("SYLVA_WHEEL"):
        return Path(os.environ["SYLVA_WHEEL"])
    wheels = sorted((ROOT / "target" / "wheels").glob("sylva-*abi3*.whl"), key=os.path.getmtime)
    return wheels[-1] if wheels else None


def build(wheel, out):
    """Writes the zip ``out`` with ``wheel`` bundled; returns ``out``."""
    wheel, out = Path(wheel), Path(out)
    if not wheel.is_file():
        raise FileNotFoundError(f"wheel {wheel} does not exist")
    manifest = (PACKAGE / "blender_manifest.toml").read_text()
    manifest = manifest.replace("wheels = []", f'wheels = ["./wheels/{wheel.name}"]')
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
    except OSError as e:
        sys.exit(f"build_zip: {e}")


if __name__ == "__main__":
    main()
