"""``datagen.safe_json``: JSON from outside, refused with one exception type when it is
malformed or beyond a bound, named by what was being read."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from datagen.safe_json import JsonInputError, JsonSyntaxError, check_value, loads_bounded


def test_ordinary_json_loads_as_json_does():
    assert loads_bounded("[1e308, -1E-400, 12e100]", what="t") == [1e308, -0.0, 12e100]
    # digits and "e" inside strings are not numbers: read as they are
    assert loads_bounded('{"sha": "0ab3e123f", "x": [2.5, 1e5]}', what="t")["x"] == [2.5, 1e5]
    text = '{"a": [1, 2.5, "é", null, true], "b": {"c": "\\u00e9"}}'
    assert loads_bounded(text.encode(), what="t") == {
        "a": [1, 2.5, "é", None, True],
        "b": {"c": "é"},
    }
    assert loads_bounded(text, what="t") == loads_bounded(text.encode(), what="t")


@pytest.mark.parametrize(
    ("data", "says"),
    [
        (b"[" * 100_000 + b"]" * 100_000, "nested deeper than 64 levels"),  # RecursionError
        (b"[" * 65 + b"]" * 65, "nested deeper than 64 levels"),  # parses, then too deep
        (b'{"a": "\\ud800"}', "lone surrogate"),
        (b'{"\\udfff": 1}', "lone surrogate"),  # in a key too
        (b'{"pad": "' + b"x" * 300_000 + b'"}', "bytes of JSON, more than the 300000 allowed"),
        (b'{"pose": [1e999, 0]}', "the number 1e999 is beyond a float's range"),  # inf otherwise
        (b"[-2.5E+400]", "the number -2.5E\\+400 is beyond a float's range"),
        (b"[" + b"9" * 400 + b".5]", "the number 9999999999.* is beyond a float's range"),
        (b'{"a": "ab3e123", "b": [ 1.5e999]}', "the number 1.5e999 is beyond a float's range"),
    ],
)
def test_json_beyond_a_bound_is_refused_naming_what(data, says):
    with pytest.raises(JsonInputError, match=says) as caught:
        loads_bounded(data, what="message on topic T", max_bytes=300_000)
    assert str(caught.value).startswith("message on topic T: ")
    assert not isinstance(caught.value, JsonSyntaxError)


@pytest.mark.parametrize(
    "data", [b"", b'{"a": 1', b"\xff\xfe", b"NaN", b"[Infinity]", b"1" * 5000, b"{} x"]
)
def test_text_that_is_not_json_is_a_syntax_error(data):
    with pytest.raises(JsonSyntaxError, match=r"^journal J line 3: not valid JSON"):
        loads_bounded(data, what="journal J line 3")


def test_exactly_the_depth_bound_is_accepted_and_check_value_walks_any_depth():
    assert loads_bounded(b"[" * 64 + b"]" * 64, what="t") is not None
    deep: list = []
    for _ in range(100_000):  # built in Python: no JSON text to parse
        deep = [deep]
    with pytest.raises(JsonInputError, match="deeper than 64"):
        check_value(deep, what="t")


@pytest.mark.parametrize(
    "text",
    [
        "[1,-1e999]",
        '{"a":-1e999}',
        "[\n1e999]",
        "[0.5e+309]",
        "[1E309 ]",
        '{"s": "e999", "n": 1e999}',
    ],
)
def test_an_overflowing_number_is_found_after_anything_a_value_may_follow(text):
    with pytest.raises(JsonInputError, match="beyond a float's range"):
        loads_bounded(text, what="t")


def _depth(value) -> int:
    if isinstance(value, dict | list):
        children = value.values() if isinstance(value, dict) else value
        return 1 + max((_depth(child) for child in children), default=0)
    return 0


# strings full of what could be taken for structure: brackets, quotes, backslashes, non-ASCII
_TRICKY_TEXT = st.text(alphabet='[]{}"\\\\/é,: ab\n', max_size=12)
_VALUES = st.recursive(
    st.none() | st.integers() | _TRICKY_TEXT,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(_TRICKY_TEXT, inner, max_size=3),
    max_leaves=40,
)


@settings(max_examples=300, deadline=None)
@given(value=_VALUES, bound=st.integers(min_value=0, max_value=6), ascii_only=st.booleans())
def test_the_depth_bound_counts_brackets_outside_strings_only(value, bound, ascii_only):
    text = json.dumps(value, ensure_ascii=ascii_only)
    if _depth(value) > bound:
        with pytest.raises(JsonInputError, match=f"nested deeper than {bound} levels"):
            loads_bounded(text, what="t", max_depth=bound)
    else:
        assert loads_bounded(text, what="t", max_depth=bound) == value


@pytest.mark.parametrize(
    "text",
    [
        '{"a": "' + "[" * 70 + '"}',  # brackets inside a string are not nesting
        r'{"a": "\\", "b": "' + "{" * 70 + '"}',  # a string ending in a backslash
        r'["\"[[[", 1]',  # an escaped quote does not end the string
    ],
)
def test_brackets_inside_strings_never_count(text):
    assert loads_bounded(text, what="t", max_depth=2) == json.loads(text)
