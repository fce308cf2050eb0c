"""The unit of data: one sample is a unique key plus named, already-encoded parts.

The part name says how its bytes are encoded (WebDataset convention): ``rgb.png``,
``depth.png``, ``seg.png``, ``semantic.png``, ``json``. Every stage (worker, wire, writer,
shard, loader) moves this one record, so a tar member ``{key}.{part}`` maps back to it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

from datagen.records import SampleMetadata

KEY_DIGITS = 9
_PART_NAME = re.compile(r"^[a-z0-9_]+(\.[a-z0-9_]+)*$")
BUILD_ID_RULE = "1-64 of [A-Za-z0-9_.-], the first a letter or digit"
_BUILD_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def sample_key(index: int) -> str:
    """Sample index -> key, zero-padded so that keys sort like indices."""
    if index < 0 or index >= 10**KEY_DIGITS:
        raise ValueError(f"sample index {index} out of range [0, {10**KEY_DIGITS})")
    return f"{index:0{KEY_DIGITS}d}"


def valid_build_id(build_id: object) -> bool:
    """Build ids go into topics, client ids and manifests, and from a manifest into exported
    YAML, Markdown and BibTeX: no ``/``, ``+``, ``#``, spaces or line breaks (``BUILD_ID_RULE``)."""
    return isinstance(build_id, str) and _BUILD_ID.fullmatch(build_id) is not None


def valid_part_name(name: str) -> bool:
    return bool(_PART_NAME.match(name)) and len(name) <= 64


@dataclass
class Sample:
    index: int
    parts: dict[str, bytes] = field(default_factory=dict)

    @property
    def key(self) -> str:
        return sample_key(self.index)

    @property
    def metadata(self) -> SampleMetadata:
        return json.loads(self.parts["json"])

    @property
    def nbytes(self) -> int:
        return sum(len(v) for v in self.parts.values())
