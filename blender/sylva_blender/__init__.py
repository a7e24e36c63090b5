"""sylva for Blender (issue 43): grow procedural trees with the sylva engine and build
them as native Blender objects (meshes, Principled BSDF materials, LOD collections).

Enabling the add-on imports the ``sylva`` Python package, extracting the wheel bundled
in ``wheels/`` when it is not installed (``install.py``); docs/blender.md describes the
panel and what is built."""

bl_info = {
    "name": "sylva",
    "author": "sylva contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > sylva",
    "description": "Procedural trees from the sylva engine, as native objects",
    "category": "Add Mesh",
}


def register():
    from . import install, ui

    ui.register(install.ensure_sylva())


def unregister():
    from . import ui

    ui.unregister()
