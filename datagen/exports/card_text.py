"""Text from a dataset made safe for the Markdown of its card (``README.md``), as the Hugging Face
Hub and GitHub render it (CommonMark with GFM tables).

A dataset is input from elsewhere: its build id, scene, class names, versions and the strings in
its samples' metadata must show as themselves, never become HTML, a link, a picture, a code span,
a new table cell or a new line. :func:`text` escapes a value for running text and table cells;
:func:`code` makes a code span of one; :func:`fenced` a fenced block that no line of its body
can close.
"""

from __future__ import annotations

import html
import re
from typing import Any

# control characters and line or paragraph separators (NEL and U+2028 included): a space each
_BREAKS = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")
# ASCII punctuation that starts a link, picture, code span, emphasis or strikethrough, ends a
# table cell, or escapes the next character (CommonMark lets any of it be backslash-escaped);
# ``<`` and ``&`` become entities
_MARKDOWN = re.compile(r"([\\`*\[\]()!|~])")
_BACKTICKS = re.compile(r"`+")


def one_line(value: Any) -> str:
    """``value`` as a string on one line: every control character or line break a space."""
    return _BREAKS.sub(" ", str(value))


def text(value: Any) -> str:
    """``value`` as Markdown text that renders as itself, in a paragraph, a heading or a cell."""
    return _MARKDOWN.sub(r"\\\1", html.escape(one_line(value), quote=False))


def code(value: Any) -> str:
    """``value`` as a code span (not for a table cell: a ``|`` there would end the cell)."""
    flat = one_line(value)
    fence = "`" * (max((len(run) for run in _BACKTICKS.findall(flat)), default=0) + 1)
    pad = " " if flat.startswith("`") or flat.endswith("`") else ""
    return f"{fence}{pad}{flat}{pad}{fence}"


def fenced(body: str, info: str = "") -> list[str]:
    """The lines of a fenced code block holding ``body``: its fence is longer than any run of
    backticks in it, so that no line of the body closes it."""
    longest = max((len(run) for run in _BACKTICKS.findall(body)), default=0)
    fence = "`" * max(3, longest + 1)
    return [fence + info, body, fence]
