"""Typing stubs of the native module ``sylva._sylva`` (crates/sylva-py/src)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import lsystem as lsystem

__version__: str

_Path = Union[str, "PathLike[str]"]
_Value = Union[bool, int, float, str, List[Any], Dict[str, Any]]

class SylvaError(Exception):
    """Any error sylva reports; ``file``, ``line`` and ``column`` say where, when known."""

    file: Optional[str]
    line: Optional[int]
    column: Optional[int]

class RecipeError(SylvaError):
    """A recipe problem: an unknown key or preset, a bad value, a TOML syntax error."""

class LsystemError(SylvaError):
    """An L-system parse or evaluation error; ``file``, ``line`` and ``column`` locate it."""

def presets() -> List[str]:
    """The names of every embedded tree preset, sorted."""

def preset_descriptions() -> Dict[str, str]:
    """Each tree preset's one-line description, by name."""

def schema() -> List[Dict[str, Any]]:
    """The recipe schema as data: one dict per key (``key``, ``section``, ``generator``,
    ``kind``, ``values``, ``default``, ``required``, ``unit``, ``doc``, ``when``,
    ``limits``), in the order of docs/recipe.md."""

class Recipe:
    """A tree recipe with where its model files are read from. ``Recipe()`` is the
    default preset's recipe."""

    def __init__(self) -> None: ...
    @staticmethod
    def preset(name: str) -> Recipe:
        """The recipe of the embedded preset ``name`` (:func:`presets` lists them)."""
    @staticmethod
    def from_toml(text: str, base_dir: Optional[_Path] = None) -> Recipe:
        """A recipe from TOML text (``preset = "name"`` starts from that preset; other
        file names resolve in ``base_dir``, default the current directory)."""
    @staticmethod
    def from_file(path: _Path) -> Recipe:
        """A ``.toml`` recipe file, or a model file (``.l``, ``.lst``, ``.str``,
        ``.json``) with the default recipe around it."""
    @staticmethod
    def from_lsystem(text: str) -> Recipe:
        """The default recipe around an L-system given as text (named ``model.l``)."""
    @staticmethod
    def schema() -> List[Dict[str, Any]]:
        """The recipe schema as data (same as :func:`sylva.schema`)."""
    def set(self, key: str, value: _Value) -> Recipe:
        """Set the dotted ``key`` (checked; raises :class:`RecipeError` and leaves the
        recipe unchanged on a bad key or value). Returns the recipe."""
    def get(self, key: str) -> Any:
        """The value of the dotted ``key`` (the schema's default when unset)."""
    def to_toml(self) -> str:
        """The recipe as TOML text."""
    def to_dict(self) -> Dict[str, Any]:
        """The recipe as a dict (the TOML table)."""
    @property
    def name(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @seed.setter
    def seed(self, seed: int) -> None: ...
    @property
    def generator(self) -> str:
        """The generator type (``lsystem``, ``import``, ``weber-penn``, …)."""
    def copy(self) -> Recipe:
        """A copy (changing it leaves this recipe alone)."""
    def __copy__(self) -> Recipe: ...
    def __deepcopy__(self, memo: Any) -> Recipe: ...
    def grow(
        self,
        seed: Optional[int] = None,
        threads: Optional[int] = None,
        timeout: Optional[float] = None,
    ) -> Tree:
        """Grow the tree (with ``seed`` instead of the recipe's, if given); the GIL is
        released meanwhile. ``threads`` caps the engine's worker threads for this grow
        (default: one per core, shared); ``threads=1`` when many Python threads grow.
        ``timeout`` (seconds) stops a longer grow with ``TimeoutError``."""

class Skeleton:
    """A branching skeleton, nodes parent-first, as numpy arrays."""

    @property
    def positions(self) -> npt.NDArray[np.float32]:
        """``(N, 3)`` node positions in metres, +Y up."""
    @property
    def parents(self) -> npt.NDArray[np.int32]:
        """``(N,)`` parent index of each node, −1 for a root."""
    @property
    def radii(self) -> npt.NDArray[np.float32]:
        """``(N,)`` node radii in metres."""
    @property
    def order(self) -> npt.NDArray[np.int32]:
        """``(N,)`` branch order (0 on the trunk)."""
    @property
    def up(self) -> npt.NDArray[np.float32]:
        """``(N, 3)`` each node's orientation reference (the turtle's up)."""
    @property
    def organ_count(self) -> int:
        """Organs (leaves, flowers) placed on the skeleton."""
    def __len__(self) -> int: ...

class Part:
    """One part of a model (``bark``, ``leaves``): the arrays of its glTF primitive."""

    @property
    def name(self) -> str: ...
    @property
    def vertices(self) -> npt.NDArray[np.float32]:
        """``(V, 3)`` vertex positions."""
    @property
    def faces(self) -> npt.NDArray[np.uint32]:
        """``(T, 3)`` triangles (vertex indices), counter-clockwise from outside."""
    @property
    def normals(self) -> npt.NDArray[np.float32]:
        """``(V, 3)`` unit vertex normals."""
    @property
    def uvs(self) -> Optional[npt.NDArray[np.float32]]:
        """``(V, 2)`` texture coordinates (glTF's top-left origin), or None."""
    @property
    def material(self) -> Dict[str, Any]:
        """``name``, ``base_color`` (linear RGBA), ``metallic``, ``roughness``,
        ``double_sided``, ``alpha_cutoff``."""
    @property
    def images(self) -> Dict[str, npt.NDArray[np.uint8]]:
        """The material's maps by role (``base_color``, ``normal``,
        ``occlusion_roughness_metallic``), each ``(H, W, C)`` uint8."""

class Tree:
    """A grown tree; ``str(tree)`` is the summary ``sylva grow`` prints."""

    @property
    def skeleton(self) -> Skeleton: ...
    @property
    def parts(self) -> List[Part]:
        """The model's parts with triangles, in the ``.glb``'s order."""
    @property
    def instances(self) -> List[Tuple[Part, npt.NDArray[np.float32]]]:
        """Instanced organs: ``(part, transforms)``, transforms ``(K, 4, 4)``."""
    def to_glb(self) -> bytes:
        """The tree as binary glTF bytes."""
    def save(self, path: _Path) -> None:
        """Write ``.glb``, ``.gltf``, ``.obj``, ``.ply``, ``.pov``, the skeleton as
        ``.lst`` / ``.json``, or the preview as ``.png``."""
    def preview(
        self, size: int = 512, azimuth: Optional[float] = None, elevation: Optional[float] = None
    ) -> bytes:
        """A ``size`` × ``size`` PNG picture of the tree (the CPU renderer)."""
    def _repr_png_(self) -> bytes: ...
    @property
    def report(self) -> Dict[str, Any]:
        """What the run built: counts, skeleton statistics, stage times, warnings."""
    @property
    def recipe(self) -> Recipe: ...
    @property
    def seed(self) -> int: ...
    @property
    def triangles(self) -> int: ...
    @property
    def vertices(self) -> int: ...

class Session:
    """A recipe and every stage's result: ``update(recipe)`` recomputes only what the
    change touches."""

    def __init__(self, recipe: Recipe) -> None: ...
    def run(self, timeout: Optional[float] = None) -> Tree:
        """Compute the tree of the current recipe; ``timeout`` (seconds) stops a longer
        run with ``TimeoutError``."""
    def update(self, recipe: Recipe, timeout: Optional[float] = None) -> Tree:
        """Make ``recipe`` the session's recipe and recompute from the first stage whose
        inputs changed."""
    @property
    def last_run(self) -> List[str]:
        """The stages the last run or update computed."""
    @property
    def recipe(self) -> Recipe: ...
    @property
    def tree(self) -> Optional[Tree]: ...
