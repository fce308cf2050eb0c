"""What every scene value checks of its fields, and the walk that writes a scene's values as
the JSON a sample stores. A value read from a dataset is hostile input: every field is checked
before it is used, and an error names the field's path (``randomisation.lighting.lights[1]``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from datagen.errors import DatasetError


class SceneValueError(DatasetError):
    """A scene value out of its range, or stored JSON that is not one."""


def as_json(values: Any) -> Any:
    """``values`` (dicts and lists of scene values and JSON) as JSON: each value's
    ``to_json()``, everything else as it is."""
    if hasattr(values, "to_json"):
        return values.to_json()
    if isinstance(values, Mapping):
        return {key: as_json(value) for key, value in values.items()}
    if isinstance(values, list | tuple):
        return [as_json(value) for value in values]
    return values


def number(where: str, value: Any, low: float = -math.inf, high: float = math.inf) -> float:
    """A finite number within [low, high] (a bool is not a number)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SceneValueError(f"{where}: expected a finite number, got {_shown(value)}")
    if not low <= value <= high:
        raise SceneValueError(f"{where}: expected a number in [{low:g}, {high:g}], got {value}")
    return value


def vector(where: str, value: Any, size: int = 3) -> tuple[float, ...]:
    """``size`` finite numbers (a list in JSON), as a tuple."""
    if not isinstance(value, list | tuple) or len(value) != size:
        raise SceneValueError(f"{where}: expected {size} numbers, got {_shown(value)}")
    return tuple(number(f"{where}[{i}]", v) for i, v in enumerate(value))


def flag(where: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise SceneValueError(f"{where}: expected true or false, got {_shown(value)}")
    return value


def choice(where: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise SceneValueError(f"{where}: expected one of {list(choices)}, got {_shown(value)}")
    return value


def fields(where: str, stored: Any, required: set[str], optional: set[str]) -> dict[str, Any]:
    """``stored`` as a JSON object with every ``required`` key and no key outside both sets."""
    if not isinstance(stored, dict):
        raise SceneValueError(f"{where}: expected an object, got {_shown(stored)}")
    if missing := sorted(required - stored.keys()):
        raise SceneValueError(f"{where}: missing {', '.join(missing)}")
    if unknown := sorted(set(stored) - required - optional, key=str):
        shown = ", ".join(repr(k)[:40] for k in unknown[:5])
        raise SceneValueError(f"{where}: unknown key(s) {shown}")
    return stored


def plain(values: tuple[float, ...] | None) -> list[float] | None:
    """A vector as JSON writes it (a list), or None."""
    return list(values) if values is not None else None


def _shown(value: Any) -> str:
    return repr(value)[:60]
