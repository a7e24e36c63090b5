"""Recipe settings as text: ``key=value`` lines (the CLI's ``--set``; a value is read as
a TOML value, else as a plain string) or a TOML overlay (``[mesh]`` tables, flattened to
dotted keys), applied over a preset's or a stored recipe with ``Recipe.set``, which
checks every key and value."""

import json

try:
    import tomllib
except ImportError:  # Python 3.10 (Blender 3.4 to 3.6 official builds)
    tomllib = None


class SettingsError(Exception):
    """A settings text that does not parse, or a key or value the recipe rejects."""


def _value(text):
    text = text.strip()
    if tomllib is not None:
        try:
            return tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            pass
    else:
        try:
            return json.loads(text)
        except ValueError:
            pass
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        return text[1:-1]
    return text


def _flatten(table, prefix=""):
    for key, value in table.items():
        if isinstance(value, dict):
            yield from _flatten(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def parse(text):
    """``[(key, value, where)]`` from a settings text; raises SettingsError."""
    lines = text.splitlines()
    if any(line.strip().startswith("[") for line in lines):
        if tomllib is None:
            raise SettingsError("settings: a TOML overlay needs Python 3.11 (use key=value lines)")
        try:
            table = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise SettingsError(f"settings: TOML error: {e}") from None
        return [(k, v, f"key `{k}`") for k, v in _flatten(table)]
    out = []
    for n, line in enumerate(lines, 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "=" not in line:
            raise SettingsError(f"settings line {n}: expected key=value, got `{line}`")
        key, value = line.split("=", 1)
        key = key.strip()
        if not key:
            raise SettingsError(f"settings line {n}: no key before `=` in `{line}`")
        out.append((key, _value(value), f"line {n} (`{key}`)"))
    return out


def apply(sylva, recipe, items):
    """Sets each ``(key, value, where)`` on ``recipe``; a rejected one raises
    SettingsError naming where it came from and the engine's reason."""
    for key, value, where in items:
        try:
            recipe.set(key, value)
        except sylva.SylvaError as e:
            raise SettingsError(f"settings {where}: {e}") from None
    return recipe
