"""The cpfg-syntax L-system language (docs/lsystem.md): derive module strings and
interpret them with sylva's 3D turtle.

Errors are :class:`sylva.LsystemError`, with ``file``, ``line`` and ``column``::

    import sylva
    text = "Lsystem: 1\\nderivation length: 3\\nAxiom: F\\nF --> F[+F]F[-F]F\\nendlsystem\\n"
    sylva.lsystem.derive(text, 1)               # 'F[+F]F[-F]F'
    sk = sylva.lsystem.skeleton(text)           # the turtle's skeleton after 3 steps
    sk = sylva.lsystem.interpret("F[+F]F")      # a module string as it stands
"""

from typing import Any, Mapping, Optional

from . import _sylva

__all__ = ["derive", "interpret", "skeleton"]


def derive(
    text: str,
    steps: Optional[int] = None,
    seed: Optional[int] = None,
    settings: Optional[Mapping[str, Any]] = None,
) -> str:
    """Derive the L-system ``text`` (what a ``.l`` file holds) for ``steps`` steps
    (default: its ``derivation length``) and return the module string, as
    ``sylva lsys derive`` prints it. ``seed`` drives stochastic productions;
    ``settings`` are dotted recipe keys (``{"generator.define": {"R": 2}}``)."""
    return _sylva.lsystem.derive(text, steps, seed, dict(settings) if settings else None)


def skeleton(
    text: str,
    steps: Optional[int] = None,
    seed: Optional[int] = None,
    settings: Optional[Mapping[str, Any]] = None,
) -> "_sylva.Skeleton":
    """The turtle's skeleton of the L-system ``text`` after ``steps`` steps (default:
    its ``derivation length``): derivation, homomorphism and turtle, as ``sylva grow``
    runs them before meshing. ``settings`` are dotted recipe keys
    (``{"generator.angle": 30}``)."""
    return _sylva.lsystem.skeleton(text, steps, seed, dict(settings) if settings else None)


def interpret(modules: str, settings: Optional[Mapping[str, Any]] = None) -> "_sylva.Skeleton":
    """The turtle's skeleton of a module string (``"F(1)[+F(0.5)]F"``, what
    :func:`derive` returns), interpreted as it stands. ``settings`` are dotted recipe
    keys for the turtle (``{"generator.angle": 30}``). An error's ``line`` and
    ``column`` point into ``modules``."""
    return _sylva.lsystem.interpret(modules, dict(settings) if settings else None)
