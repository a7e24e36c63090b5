"""sylva: procedural trees and plants, from Python.

Grow a tree from one of the embedded presets, read it as numpy arrays, save it in
any format the ``sylva`` CLI writes, or show it in Jupyter::

    import sylva
    tree = sylva.Recipe.preset("wp-quaking-aspen").grow(seed=7)
    tree.skeleton.positions     # (N, 3) float32
    tree.save("aspen.glb")
    tree                        # a picture in a notebook

The engine is Rust (the ``sylva`` crate); this package is a thin front end over it
(the native module ``sylva._sylva``, built with PyO3). docs/python.md has examples.
"""

from . import lsystem
from ._sylva import (
    LsystemError,
    Part,
    Recipe,
    RecipeError,
    Session,
    Skeleton,
    SylvaError,
    Tree,
    __version__,
    preset_descriptions,
    presets,
    schema,
)

__all__ = [
    "LsystemError",
    "Part",
    "Recipe",
    "RecipeError",
    "Session",
    "Skeleton",
    "SylvaError",
    "Tree",
    "__version__",
    "lsystem",
    "preset_descriptions",
    "presets",
    "schema",
]
