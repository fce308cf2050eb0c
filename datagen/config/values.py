"""The values of a config as YAML reads them, against the field types of its dataclasses:
whether one fits (:func:`fits`), what one should look like in words (:func:`shape`), and a short
repr for messages whatever a value's size (:func:`show`)."""

from __future__ import annotations

import math
import reprlib
import types
import typing
from typing import Any


def fits(tp: Any, value: Any) -> bool:
    """Whether ``value`` (as YAML reads it) is a value of the field type ``tp``. Booleans are not
    numbers, numbers are not booleans, NaN and infinities are not numbers of a config."""
    if tp is bool:
        return isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        return isinstance(value, int) or math.isfinite(value)
    if tp is str:
        return isinstance(value, str) and "\x00" not in value
    if tp is type(None):
        return value is None
    args = typing.get_args(tp)
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return any(fits(arg, value) for arg in args)
    if typing.get_origin(tp) is tuple:
        if not isinstance(value, list | tuple):
            return False
        if len(args) == 2 and args[1] is Ellipsis:
            return all(fits(args[0], v) for v in value)
        return len(value) == len(args) and all(map(fits, args, value))
    raise TypeError(f"no check for config field type {tp}")  # a new field type: add it here


_NAMES = {bool: "true or false", int: "whole number", float: "finite number", str: "string"}


def shape(tp: Any, example: Any = None) -> str:
    """What a value of field type ``tp`` looks like, in words ('a [min, max] pair of whole
    numbers, e.g. [3, 12]'); ``example``: the field's default, shown for lists."""
    if tp in _NAMES:
        return _NAMES[tp] if tp is bool else f"a {_NAMES[tp]}"
    args = typing.get_args(tp)
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return " or ".join("null" if a is type(None) else shape(a, example) for a in args)
    if len(args) == 2 and args[1] is Ellipsis:
        text = f"a list of {_NAMES[args[0]]}s"
    elif len(args) == 2:
        text = f"a [min, max] pair of {_NAMES[args[0]]}s"
    else:
        text = f"a list of {len(args)} {_NAMES[args[0]]}s [x, y, z]"
    if isinstance(example, tuple) and example:
        shown = ", ".join(map(str, example[:3])) + (", ..." if len(example) > 3 else "")
        text += f", e.g. [{shown}]"
    return text


_repr = reprlib.Repr()
_repr.maxstring = _repr.maxother = 60
_repr.maxlist = _repr.maxtuple = _repr.maxdict = _repr.maxset = 6
_repr.maxlevel = 3


def show(value: Any) -> str:
    """A short repr for a message, whatever the value's size (an int of 10^5 digits included)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of about {int(value.bit_length() * 0.30103)} digits"
    return _repr.repr(value)


def show_key(key: Any) -> str:
    """A key as typed (``objects.colour``), quoted if it is not plain text."""
    if isinstance(key, str) and key.isprintable():
        return key[:60] + ("..." if len(key) > 60 else "")
    return show(key)
