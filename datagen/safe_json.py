"""JSON that comes from outside (the network, a dataset on disk, a journal) decoded with bounds.

``json.loads`` alone accepts 100k-deep nesting (``RecursionError`` here or later, in whatever
walks the value), ``NaN``/``Infinity``, numbers beyond a float's range (``1e999`` becomes inf),
escaped lone surrogates (``"\\ud800"``, which fail later when the string is encoded) and any
size. ``loads_bounded`` refuses each of these with a
``JsonInputError`` that names what was being read, so a caller catches one exception type.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

MAX_DEPTH = 64  # nesting of objects and arrays; datagen's own documents use fewer than 10
MAX_DOCUMENT_BYTES = 16 * 2**20  # default size bound; callers pass tighter ones
# text decoded from UTF-8 holds no surrogate; only a \uD800-\uDFFF escape can put one in a value
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")
# a JSON string, escapes included, written so that runs of plain characters match at once
_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_NOT_BRACKET = bytes(c for c in range(256) if c not in b"[]{}")  # deleted by bytes.translate
_ONE_BRACKET_KIND = bytes.maketrans(b"{}", b"[]")
# Only a number with an exponent of three digits or more, or with 300 digits or more, can
# overflow a float to inf (``_may_overflow``); a hex digest in a string ("..b3e123..") is not
# such a number, and no longer sends every float of a document through ``_finite_float``.
_EXPONENT = re.compile(r"[eE][+-]?[0-9]{3}")
_ALL_DIGITS_ZERO = bytes.maketrans(b"123456789", b"000000000")
_BEFORE_NUMBER = frozenset(" \t\r\n[,:")


class JsonInputError(ValueError):
    """A JSON document from outside is malformed or exceeds a bound; the text says which."""


class JsonSyntaxError(JsonInputError):
    """The text is not JSON at all (cut short, not UTF-8, ``NaN``), as opposed to JSON beyond a
    bound: a reader of append-only files can tell a cut-short last write from other damage."""


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


class _BeyondFloat(ValueError):
    pass


def _finite_float(text: str) -> float:
    value = float(text)
    if math.isinf(value):
        raise _BeyondFloat(text[:40])
    return value


def loads_bounded(
    data: bytes | bytearray | memoryview | str,
    *,
    what: str,
    max_bytes: int = MAX_DOCUMENT_BYTES,
    max_depth: int = MAX_DEPTH,
) -> Any:
    """The value of ``data`` (UTF-8 JSON), or ``JsonInputError`` naming ``what`` (e.g.
    ``"control message on topic T"`` or ``"journal /d/.writer-0.journal line 3"``)."""
    size = len(data.encode("utf-8", "surrogatepass")) if isinstance(data, str) else len(data)
    if size > max_bytes:
        raise JsonInputError(f"{what}: {size} bytes of JSON, more than the {max_bytes} allowed")
    try:
        text = data if isinstance(data, str) else bytes(data).decode("utf-8")
        encoded = text.encode("utf-8")  # a str may hold a lone surrogate itself
        # a number like 1e999 parses to inf: checked only where one may be (parse_float per
        # number costs 2x on a sample's metadata)
        parse_float = _finite_float if _may_overflow(text, encoded) else None
        value = json.loads(text, parse_constant=_refuse_constant, parse_float=parse_float)
    except RecursionError:
        raise JsonInputError(f"{what}: JSON nested deeper than {max_depth} levels") from None
    except _BeyondFloat as e:
        raise JsonInputError(f"{what}: the number {e} is beyond a float's range") from None
    except (ValueError, TypeError) as e:  # UnicodeDecodeError and JSONDecodeError included
        raise JsonSyntaxError(f"{what}: not valid JSON ({_short(e)})") from None
    # walking the value costs 2-4x json.loads on a sample's metadata: look at the text instead,
    # and walk only where an escape may have put a lone surrogate into a string
    if _SURROGATE_ESCAPE.search(text):
        check_value(value, what=what, max_depth=max_depth)
    elif _nesting_exceeds(encoded, max_depth):
        raise JsonInputError(f"{what}: JSON nested deeper than {max_depth} levels")
    return value


def _may_overflow(text: str, encoded: bytes) -> bool:
    """Whether ``text`` (``encoded``: its UTF-8) may hold a JSON number that parses to inf: 300
    digits in a row, or an exponent of three digits standing as a number (a digit before the
    "e", the digits and a "-" before those preceded by what precedes a JSON value, nothing of a
    word after)."""
    if b"0" * 300 in encoded.translate(_ALL_DIGITS_ZERO):
        return True
    for match in _EXPONENT.finditer(text):
        end = match.end()
        while end < len(text) and text[end].isdigit():
            end += 1
        if end < len(text) and (text[end].isalnum() or text[end] in "_."):
            continue  # "3e123abc": part of a word, not a number
        start = match.start()
        if start == 0 or not text[start - 1].isdigit():
            continue
        while start > 0 and (text[start - 1].isdigit() or text[start - 1] == "."):
            start -= 1
        if start > 0 and text[start - 1] == "-":
            start -= 1
        if start == 0 or text[start - 1] in _BEFORE_NUMBER:
            return True
    return False


def _nesting_exceeds(encoded: bytes, max_depth: int) -> bool:
    """Whether valid JSON ``encoded`` (UTF-8) nests deeper than ``max_depth``: the strings and
    everything but brackets taken out, each pass removes every innermost bracket pair, so the
    brackets are gone after exactly depth passes. Bytes, not text: no byte of a multi-byte
    UTF-8 character is a quote, a backslash or a bracket."""
    # without a backslash no escape hides a quote: every other piece between quotes is outside
    escaped = b"\\" in encoded
    outside = _STRING.sub(b"", encoded) if escaped else b"".join(encoded.split(b'"')[::2])
    brackets = outside.translate(_ONE_BRACKET_KIND, _NOT_BRACKET)
    for _ in range(max_depth):
        if not brackets:
            return False
        brackets = brackets.replace(b"[]", b"")
    return bool(brackets)


def check_value(value: Any, *, what: str, max_depth: int = MAX_DEPTH) -> None:
    """Raises ``JsonInputError`` unless ``value`` nests at most ``max_depth`` levels and every
    string in it (keys too) encodes as UTF-8. Iterative: safe on any depth."""
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, str):
            _check_text(item, what)
        elif isinstance(item, dict | list):
            if depth >= max_depth:
                raise JsonInputError(f"{what}: JSON nested deeper than {max_depth} levels")
            if isinstance(item, dict):
                for key in item:
                    _check_text(key, what)
            children = item.values() if isinstance(item, dict) else item
            stack.extend((v, depth + 1) for v in children if isinstance(v, str | dict | list))


def _check_text(text: str, what: str) -> None:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise JsonInputError(f"{what}: a string holds a lone surrogate (not UTF-8)") from None


def _short(error: Exception) -> str:
    text = str(error)
    return text if len(text) <= 120 else text[:117] + "..."
