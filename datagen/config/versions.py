"""Config versions: this datagen writes version 2 and reads version 1 too, each key version 2
renamed read under its new name with a one-line notice."""

from __future__ import annotations

import logging
from typing import Any

from datagen.config.values import show
from datagen.errors import ConfigError

CONFIG_VERSION = 2
READABLE = (1, CONFIG_VERSION)
# (section, version 1's name) -> version 2's: output.sinks listed formats, not writers
RENAMED_IN_VERSION_2 = {("output", "sinks"): "formats"}
LOG = logging.getLogger("datagen.config")


def as_current_version(data: dict[str, Any], source: str) -> dict[str, Any]:
    """``data`` (a config's top-level mapping) in version :data:`CONFIG_VERSION`'s keys;
    ConfigError naming ``source`` for a version this datagen does not read."""
    version = data.get("version", CONFIG_VERSION)
    if type(version) is not int or version not in READABLE:
        raise ConfigError(
            f"{source}: version: this datagen reads config versions 1 and {CONFIG_VERSION}, "
            f"got {show(version)}"
        )
    return _from_version_1(data, source) if version == 1 else data


def _from_version_1(data: dict[str, Any], source: str) -> dict[str, Any]:
    data = {**data, "version": CONFIG_VERSION}
    for (section, old), new in RENAMED_IN_VERSION_2.items():
        values = data.get(section)
        if not isinstance(values, dict) or old not in values:
            continue
        if new in values:
            raise ConfigError(
                f"{source}: {section}.{old} and {section}.{new}: the same key, named {old!r} in "
                f"config version 1; keep {new!r}"
            )
        data[section] = {(new if k == old else k): v for k, v in values.items()}
        LOG.warning(
            "%s: config version 1: %s.%s is read as %s.%s (write version: %d to drop this notice)",
            source,
            section,
            old,
            section,
            new,
            CONFIG_VERSION,
        )
    return data
