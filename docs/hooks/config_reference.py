"""MkDocs hook: the configuration reference, generated from the config schema at build time.

Walks ``datagen.config.BuildConfig`` (frozen dataclasses; a field's ``metadata`` holds its range
and unit: ``min``, ``max``, ``doc``) and replaces ``<!-- config-reference -->`` in
``configuration.md`` with one table per section: every key with its type, default, range, unit
and meaning. Keys, types, defaults and ranges come from the code, so the page cannot drift from
what ``datagen`` checks; the longer meanings come from ``configs/README.md``'s table."""

from __future__ import annotations

import dataclasses
import json
import re
import typing
from pathlib import Path
from typing import Any

MARKER = "<!-- config-reference -->"
PAGE = "configuration.md"
REPO = Path(__file__).resolve().parents[2]


def config_keys() -> list[tuple[str, str, list[dict[str, str]]]]:
    """(section, its dataclass's name, rows) for the top level and every section, in order."""
    from datagen.config import BuildConfig
    from datagen.config.values import shape

    meanings = _readme_meanings()
    top: list[dict[str, str]] = []
    sections = [("", "BuildConfig", top)]
    hints = typing.get_type_hints(BuildConfig)
    for f in dataclasses.fields(BuildConfig):
        if dataclasses.is_dataclass(hints[f.name]):
            rows = _rows(f"{f.name}.", hints[f.name], meanings, shape)
            sections.append((f.name, hints[f.name].__name__, rows))
        else:
            top.append(_row("", f, hints[f.name], meanings, shape))
    return sections


def _rows(prefix: str, cls: type, meanings: dict, shape) -> list[dict[str, str]]:
    """The rows of a section, a nested section's keys (``robot.urdf.file``) in its place."""
    rows = []
    for g, tp in _fields(cls):
        if dataclasses.is_dataclass(tp):
            rows += _rows(f"{prefix}{g.name}.", tp, meanings, shape)
        else:
            rows.append(_row(prefix, g, tp, meanings, shape))
    return rows


def _fields(cls: type) -> list[tuple[dataclasses.Field, Any]]:
    hints = typing.get_type_hints(cls)
    return [(f, hints[f.name]) for f in dataclasses.fields(cls)]


def _row(prefix: str, f: dataclasses.Field, tp: Any, meanings: dict, shape) -> dict[str, str]:
    if f.default is not dataclasses.MISSING:
        default = f.default
    elif f.default_factory is not dataclasses.MISSING:
        default = f.default_factory()
    else:
        default = None
    key = prefix + f.name
    if "min" in f.metadata:
        allowed = f"{_number(f.metadata['min'])} .. {_number(f.metadata['max'])}"
    else:
        allowed = meanings.get(key, ("", ""))[1]
    return {
        "key": key,
        "type": shape(tp),
        "default": json.dumps(_plain(default)),
        "allowed": allowed,
        "unit": f.metadata.get("doc", ""),
        "meaning": meanings.get(key, ("", ""))[0],
    }


def _plain(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def _number(value: float) -> str:
    if isinstance(value, int) and value >= 10**6:
        for base in (10, 2):
            for exp in range(6, 64):
                for off in (0, -1):
                    if base**exp + off == value:
                        return f"{base}^{exp}" + ("-1" if off else "")
    return str(value)


def _readme_meanings() -> dict[str, tuple[str, str]]:
    """key -> (meaning, allowed) from the rows of configs/README.md's table."""
    found: dict[str, tuple[str, str]] = {}
    path = REPO / "configs" / "README.md"
    if not path.exists():
        return found
    for line in path.read_text().splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        if len(cells) != 4 or not cells[0].startswith("`"):
            continue
        for key in re.findall(r"`([\w.]+)`", cells[0]):
            found.setdefault(key, (_relinked(cells[2]), _relinked(cells[3])))
    return found


def _relinked(text: str) -> str:
    """Links of configs/README.md as seen from docs/: pages of docs/ stay links, the rest code."""
    text = text.replace("](../docs/", "](")
    return re.sub(r"\[([^]]*)\]\((\.\./[^)]*)\)", r"\1 (`\2`)", text)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def render() -> str:
    out = []
    for section, cls_name, rows in config_keys():
        title = f"`{section}`" if section else "Top level"
        out += [f"### {title}", "", f"Dataclass `{cls_name}`.", ""]
        out += ["| key | type | default | allowed | unit | meaning |", "|---|---|---|---|---|---|"]
        for r in rows:
            cells = [f"`{r['key']}`", r["type"], f"`{r['default']}`", r["allowed"], r["unit"]]
            cells.append(r["meaning"])
            out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
        out.append("")
    return "\n".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise ValueError(f"{PAGE} has no {MARKER} for the generated configuration reference")
    return markdown.replace(MARKER, render())
