"""MkDocs hook: architecture.md's layer and module tables, generated from the code at build time.

``<!-- layer-table -->`` becomes the layers ``lint-imports`` checks (pyproject.toml's layers
contract), each package or module with the first sentence of its docstring;
``<!-- module-table -->`` becomes one row per package with each module and the first sentence
of its docstring. Names and jobs come from the code, so the tables cannot drift from it; a
module without a docstring fails the build (and ``tests/test_architecture.py``)."""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

PAGE = "architecture.md"
LAYER_MARKER = "<!-- layer-table -->"
MODULE_MARKER = "<!-- module-table -->"
REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "datagen"


def first_sentence(path: Path) -> str:
    """The first sentence of ``path``'s docstring (a package: its ``__init__.py``), one line."""
    source = path / "__init__.py" if path.is_dir() else path
    doc = ast.get_docstring(ast.parse(source.read_text(encoding="utf-8")))
    if not doc:
        raise ValueError(f"{source.relative_to(REPO)}: no docstring to describe it by")
    paragraph = " ".join(doc.split("\n\n")[0].split())
    sentence = re.split(r"(?<=[.!?])\s+(?=[A-Z`(*:])", paragraph)[0]
    return sentence.replace("|", "\\|")


def layers() -> list[list[str]]:
    """The layers contract's rows, top first: dotted names under ``datagen``."""
    tool = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]
    contract = next(c for c in tool["importlinter"]["contracts"] if c["type"] == "layers")
    return [
        [name.strip().removeprefix("datagen.") for name in row.split("|")]
        for row in contract["layers"]
    ]


def _path(dotted: str) -> Path:
    base = PACKAGE.joinpath(*dotted.split("."))
    return base if base.is_dir() else base.with_suffix(".py")


def layer_table() -> str:
    rows = ["| layer | package or module | what it is (its docstring) |", "|---|---|---|"]
    for number, names in enumerate(layers(), 1):
        for k, name in enumerate(names):
            rows.append(
                f"| {number if k == 0 else ''} | `{name}` | {first_sentence(_path(name))} |"
            )
    return "\n".join(rows)


def module_table() -> str:
    rows = ["| package | module | what it is (its docstring) |", "|---|---|---|"]
    folders = sorted({p.parent for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts})
    for package in folders:
        modules = sorted(p for p in package.glob("*.py") if p.name != "__init__.py")
        for k, module in enumerate(modules):
            where = f"`{package.relative_to(REPO)}/`" if k == 0 else ""
            rows.append(f"| {where} | `{module.name}` | {first_sentence(module)} |")
    return "\n".join(rows)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri != PAGE:
        return markdown
    for marker in (LAYER_MARKER, MODULE_MARKER):
        if marker not in markdown:
            raise ValueError(f"{PAGE}: {marker} is missing")
    return markdown.replace(LAYER_MARKER, layer_table()).replace(MODULE_MARKER, module_table())
