"""A table of names a user chooses from (``Registry``), with the plug-ins installed packages add
through entry points: loaded the first time the table is read; one that cannot be used is
skipped and reported once on the ``datagen.plugins`` logger, and choosing its name is an error
that says why. ``datagen.registries`` holds the tables themselves and their records."""

from __future__ import annotations

import importlib
import logging
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Generic, Protocol, TypeVar

from datagen.errors import ConfigError


class _Named(Protocol):
    @property
    def name(self) -> str: ...


T = TypeVar("T", bound=_Named)
PLUGIN_LOG = logging.getLogger("datagen.plugins")  # one warning per plug-in skipped


def resolve(ref: str) -> Any:
    """``"package.module:attribute"`` -> the attribute, imported on first use."""
    module, _, attribute = ref.partition(":")
    return getattr(importlib.import_module(module), attribute)


@dataclass(frozen=True)
class PluginFailure:
    """An entry point that was skipped: its name, its distribution and why."""

    name: str
    distribution: str  # "name version"
    reason: str

    def __str__(self) -> str:
        return _plugin(self.name, self.distribution)


def _plugin(entry_name: str, distribution: str) -> str:
    return f"plug-in {entry_name!r} (from distribution {distribution})"


class Registry(Mapping[str, T], Generic[T]):
    """A read-only name -> record table with the error message every chooser shares."""

    def __init__(self, kind: str, group: str, records: list[T]):
        self.kind, self.group = kind, group
        self.record_type = type(records[0])
        names = [r.name for r in records]
        if twice := sorted({n for n in names if names.count(n) > 1}):
            raise ValueError(f"{kind} registry: {', '.join(twice)} listed more than once")
        self._records = dict(zip(names, records, strict=True))
        self._builtins = frozenset(self._records)
        self._plugins_loaded = False
        self.failures: dict[str, PluginFailure] = {}  # entry point name -> why it was skipped

    def _load_plugins(self) -> None:
        if self._plugins_loaded:
            return
        self._plugins_loaded = True
        owners: dict[str, str] = {}  # a plug-in's record name -> its entry point's description
        for entry in _entry_points(self.group):
            distribution = _distribution(entry)
            try:
                record = self._plugin_record(entry, owners)
            except _Unusable as exc:
                failure = PluginFailure(entry.name, distribution, str(exc))
                self.failures.setdefault(entry.name, failure)
                PLUGIN_LOG.warning("%s skipped: %s", failure, failure.reason)
                continue
            self._records[record.name] = record
            owners[record.name] = _plugin(entry.name, distribution)

    def _plugin_record(self, entry: metadata.EntryPoint, owners: dict[str, str]) -> T:
        try:
            record = entry.load()
        except (Exception, SystemExit) as exc:  # a plug-in's import may raise anything
            raise _Unusable(f"loading {entry.value} raised {_one_line(exc)}") from None
        expected = self.record_type.__name__
        if not isinstance(record, self.record_type):
            raise _Unusable(f"{entry.value} is not a {expected} but a {type(record).__name__}")
        name = record.name
        if not isinstance(name, str) or not name.strip():
            raise _Unusable(f"{entry.value}: its {expected} has no name")
        if name in self._builtins:
            raise _Unusable(f"{entry.value} registers {self.kind} {name!r}, a built-in {self.kind}")
        if name in owners:
            raise _Unusable(
                f"{entry.value} registers {self.kind} {name!r}, already registered by {owners[name]}"
            )
        return record

    def __getitem__(self, name: str) -> T:
        self._load_plugins()
        return self._records[name]

    def __iter__(self) -> Iterator[str]:
        self._load_plugins()
        return iter(self._records)

    def __len__(self) -> int:
        self._load_plugins()
        return len(self._records)

    def names(self) -> list[str]:
        return list(self)

    def unknown(self, name: str) -> str:
        """Why ``name`` is not a choice: the choices, and the failure of a plug-in by that name."""
        text = f"expected one of {self.names()} ({self.kind}), got {name!r}"
        failure = self.failures.get(name)
        return f"{text}; {failure} failed to load: {failure.reason}" if failure else text

    def check(self, name: str, where: str) -> T:
        """The record of ``name``, or a ConfigError naming ``where`` and the choices."""
        if name not in self:
            raise ConfigError(f"{where}: {self.unknown(name)}")
        return self[name]


class _Unusable(Exception):
    """An entry point that cannot be registered; the text says why."""


def _one_line(exc: BaseException) -> str:
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) <= 300 else text[:297] + "..."


def _distribution(entry: metadata.EntryPoint) -> str:
    dist = getattr(entry, "dist", None)
    return f"{dist.name} {dist.version}" if dist is not None else "unknown"


_reported_distributions: set[str] = set()


def _entry_points(group: str) -> list[metadata.EntryPoint]:
    """The group's entry points. Where one installed distribution's entry_points.txt cannot be
    parsed (``importlib.metadata`` then fails for all), that distribution is reported once and
    the others' are read one by one."""
    try:
        return list(metadata.entry_points(group=group))
    except Exception:  # a malformed entry_points.txt anywhere; found below
        pass
    found, seen = [], set()
    for dist in metadata.distributions():
        name = dist.metadata["Name"] or "(no name)"
        if (normalised := re.sub(r"[-_.]+", "-", name).lower()) in seen:
            continue  # the first on sys.path wins, as in importlib.metadata.entry_points
        seen.add(normalised)
        try:
            found += list(dist.entry_points.select(group=group))
        except Exception as exc:  # the distribution's own metadata is broken
            if name not in _reported_distributions:
                _reported_distributions.add(name)
                PLUGIN_LOG.warning(
                    "plug-ins of distribution %s skipped: its entry_points.txt cannot be read (%s)",
                    name,
                    _one_line(exc),
                )
    return found


def choices(registry: Registry) -> Callable[[str], str]:
    """An argparse ``type`` that accepts the registry's names."""

    def parse(text: str) -> str:
        import argparse

        if text not in registry:
            raise argparse.ArgumentTypeError(registry.unknown(text))
        return text

    return parse


# --- the tables ----------------------------------------------------------------------------------
