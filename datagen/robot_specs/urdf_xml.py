"""A URDF's XML read within bounds: the one parser of every URDF datagen reads (a user's, the
shipped and composed ones, the planner's copies), so a user's file is bounded before SAPIEN's
loader or mplib ever sees it.

A URDF is a regular file of at most ``MAX_URDF_BYTES`` (a link to ``/dev/zero`` or a FIFO is
never read), nested at most ``MAX_DEPTH`` elements deep, with no attribute longer than
``MAX_ATTRIBUTE_CHARS`` and no DOCTYPE (so no entity of any kind: the stdlib parser would expand
internal ones, and SAPIEN's lxml reads the file again). The largest URDF mani-skill ships is
45 kB and 7 elements deep. Every refusal is a ConfigError of one line naming the file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from datagen.errors import ConfigError
from datagen.images import ImageInputError, read_regular_file

MAX_URDF_BYTES = 4 * 2**20
MAX_DEPTH = 32
MAX_ATTRIBUTE_CHARS = 4096  # a file name may be as long as PATH_MAX


class _BoundedTree:
    """An ``ET.TreeBuilder`` that refuses a DOCTYPE, a too deep element or a too long attribute
    as the parser reaches it."""

    def __init__(self, path: Path) -> None:
        self._path, self._builder, self._depth = path, ET.TreeBuilder(), 0

    def start(self, tag: str, attrib: dict[str, str]) -> ET.Element:
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise ConfigError(f"{self._path}: elements nested deeper than {MAX_DEPTH}")
        for key, value in attrib.items():
            if len(value) > MAX_ATTRIBUTE_CHARS:
                raise ConfigError(
                    f"{self._path}: <{tag}> {key}: an attribute longer than "
                    f"{MAX_ATTRIBUTE_CHARS} characters"
                )
        return self._builder.start(tag, attrib)

    def end(self, tag: str) -> ET.Element:
        self._depth -= 1
        return self._builder.end(tag)

    def data(self, text: str) -> None:
        self._builder.data(text)

    def doctype(self, name: str, pubid: str | None, system: str | None) -> None:
        raise ConfigError(f"{self._path}: a DOCTYPE (entities) in a URDF; expected none")

    def close(self) -> ET.Element:
        return self._builder.close()


def read_urdf_bytes(path: Path) -> bytes:
    """The bytes of the URDF at ``path`` (a regular file within ``MAX_URDF_BYTES``)."""
    try:
        return read_regular_file(path, max_bytes=MAX_URDF_BYTES)
    except ImageInputError as error:
        raise ConfigError(f"{error} for a URDF") from None


def parse_urdf_xml(path: Path) -> ET.Element:
    """The root element of the URDF at ``path``; a ConfigError naming the file and the bound it
    exceeds, or why it is not XML."""
    data = read_urdf_bytes(path)
    parser = ET.XMLParser(target=_BoundedTree(path))
    try:
        # one feed: expat 2.5 scans an unfinished token again on every feed, which made a 50 MB
        # attribute fed in 64 kB chunks take a minute
        parser.feed(data)
        root = parser.close()
    except ET.ParseError as error:
        raise ConfigError(f"{path}: not a readable URDF ({error})") from None
    if root.tag != "robot":
        raise ConfigError(f"{path}: expected a <robot> element, got <{root.tag}>")
    return root
