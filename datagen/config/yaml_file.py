"""Reading a config file: bounded, UTF-8, YAML through a safe loader whose aliases cannot
expand into more than a config's worth of values. Every failure is a ConfigError naming the
path."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import yaml

from datagen.errors import ConfigError

# A config is about 150 values in a few KiB of YAML; these bounds refuse anything that is not,
# before it can take time or memory (an "alias bomb" expands 1 KiB into 10^9 values).
MAX_CONFIG_BYTES = 1 << 20
MAX_CONFIG_VALUES = 10_000


class _ConfigLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses a document whose aliases, expanded, hold more than
    ``MAX_CONFIG_VALUES`` values or refer to themselves: PyYAML shares an aliased node, so the
    blow-up would only happen later, when the config is walked."""

    def compose_document(self):
        node = super().compose_document()
        _count_values(node)
        return node


class _TooLarge(yaml.YAMLError):
    pass


def _count_values(root: yaml.Node) -> int:
    """Values in the document with every alias expanded (each alias counts the whole value it
    refers to), in time linear in the number of distinct nodes: a shared node is sized once."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def size(node: yaml.Node) -> int:
        if id(node) in sizes:
            return sizes[id(node)]
        if id(node) in open_nodes:
            raise _TooLarge("a YAML alias refers to a node that contains it (a recursive value)")
        open_nodes.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            children = node.value
        elif isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        else:
            children = []
        total = 1
        for child in children:
            total += size(child)
            if total > MAX_CONFIG_VALUES:
                raise _TooLarge(
                    f"its YAML aliases expand to more than {MAX_CONFIG_VALUES} values "
                    "(a config has about 150)"
                )
        open_nodes.discard(id(node))
        sizes[id(node)] = total
        return total

    return size(root)


def _read_config_text(path: Path) -> str:
    """The file's text, or a ConfigError naming the path and what is wrong with it."""
    try:
        if path.is_dir():
            raise ConfigError(f"{path}: is a directory; expected a YAML config file")
        if not path.exists():
            raise ConfigError(f"{path}: no such config file")
        if not path.is_file():
            raise ConfigError(f"{path}: not a regular file; expected a YAML config file")
        with open(path, "rb") as f:
            raw = f.read(MAX_CONFIG_BYTES + 1)
    except ConfigError:
        raise
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the config file: {exc.strerror}") from None
    except ValueError as exc:  # e.g. a NUL character in the path
        raise ConfigError(f"{path!r}: not a usable path: {exc}") from None
    if len(raw) > MAX_CONFIG_BYTES:
        raise ConfigError(
            f"{path}: larger than {MAX_CONFIG_BYTES // 2**20} MiB; a config is a small YAML file"
        )
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})"
        ) from None


def read_yaml(path: Path) -> Any:
    """The YAML document in ``path`` as plain data (dicts, lists, strings, numbers, ...)."""
    stream = io.StringIO(_read_config_text(path))
    stream.name = str(path)  # YAML errors say "in <path>, line L, column C"
    try:
        return yaml.load(stream, Loader=_ConfigLoader)  # a SafeLoader: plain data only
    except _TooLarge as exc:
        raise ConfigError(f"{path}: refused: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {_one_line(exc)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: not valid YAML: nested too deeply for a config") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())
