"""Makes ``import sylva`` work inside Blender.

Blender 4.2+ installs the wheels that ``blender_manifest.toml`` lists by itself. For the
legacy add-on path (Blender 3.4 to 4.1, and Debian's Blender, whose Python is the
system's and usually has no pip and no network), the abi3 wheel bundled in ``wheels/``
is a zip archive: it is extracted, once, into ``_site/`` next to this file and that
folder is put on ``sys.path``. No pip and no network are involved; numpy, the package's
one dependency, ships with Blender (Debian: python3-numpy)."""

import importlib
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SITE = HERE / "_site"


def bundled_wheel():
    """The wheel inside the add-on's ``wheels/`` folder, or None."""
    wheels = sorted((HERE / "wheels").glob("sylva-*.whl"))
    return wheels[-1] if wheels else None


def ensure_sylva():
    """Imports and returns the ``sylva`` module, extracting the bundled wheel first if
    it is not importable. Raises ImportError naming what is missing and where."""
    try:
        return importlib.import_module("sylva")
    except ImportError:
        pass
    wheel = bundled_wheel()
    if wheel is None:
        raise ImportError(
            f"sylva is not installed and no wheel is bundled in {HERE / 'wheels'}: "
            "build the add-on zip with blender/build_zip.py"
        )
    site = _extract(wheel)
    if str(site) not in sys.path:
        sys.path.insert(0, str(site))
    importlib.invalidate_caches()
    try:
        return importlib.import_module("sylva")
    except ImportError as e:
        msg = f"the wheel {wheel.name} extracted into {site} does not import: {e}"
        raise ImportError(msg) from e


def _extract(wheel):
    """Extracts ``wheel`` (once per wheel name) into ``_site/`` beside this file, or,
    where that folder is read-only (a system-wide install), into Blender's user
    scripts folder (``sylva_site``). Returns the folder."""
    places = [SITE]
    try:
        import bpy

        places.append(Path(bpy.utils.user_resource("SCRIPTS", path="sylva_site")))
    except (ImportError, AttributeError, TypeError):
        pass
    errors = []
    for site in places:
        stamp = site / ".wheel"
        try:
            if not stamp.is_file() or stamp.read_text() != wheel.name:
                site.mkdir(parents=True, exist_ok=True)
                with zipfile.ZipFile(wheel) as zf:
                    zf.extractall(site)
                stamp.write_text(wheel.name)
            return site
        except OSError as e:
            errors.append(f"{site}: {e}")
    raise ImportError(f"cannot extract {wheel.name}: " + "; ".join(errors))
