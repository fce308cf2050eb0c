"""What an export leaves out of the samples it exports: the kinds of their parts (a frame number
as ``<k>``: ``f<k>.d0.flow.png``) of which nothing the export writes holds a single one. The
HDF5 and robomimic exports state them as a ``left_out`` attribute, LeRobot under
``datagen.left_out`` in ``meta/info.json``; docs/exports.md says what each export leaves out."""

from __future__ import annotations

from collections.abc import Iterable

from datagen.exports.croissant import part_kinds


class LeftOut:
    """The part kinds the exported samples hold and those the export wrote some part of."""

    def __init__(self) -> None:
        self.held: set[str] = set()
        self.written: set[str] = set()

    def add(self, part_names: Iterable[str], written: Iterable[str]) -> None:
        """One exported sample: its parts, and those of them the export wrote."""
        self.held |= set(part_kinds(list(part_names)))
        self.written |= set(part_kinds(list(written)))

    def kinds(self) -> list[str]:
        return sorted(self.held - self.written)
