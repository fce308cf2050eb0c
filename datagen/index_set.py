"""Sets of sample indices and keys in about one bit per index, so what a writer or the
coordinator remembers of every durable sample stays small however long the build: 100,000
keys take 12.5 KiB here against some 10 MB as a ``set`` of strings.

``IndexSet``: non-negative ints in pages of ``PAGE`` bits (a page exists only once one of its
indices was added, so a stray large index costs one page, not a bitmap up to it).
``KeySet``: sample keys; the canonical ones (``datagen.sample.sample_key``) live in an
``IndexSet``, any other string in a plain set.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, MutableSet

from datagen.sample import KEY_DIGITS, sample_key

PAGE = 1 << 16  # indices per page: 8 KiB


class IndexSet(MutableSet[int]):
    def __init__(self, indices: Iterable[int] = ()):
        self._pages: dict[int, bytearray] = {}
        self._count = 0
        self.update(indices)

    def __contains__(self, index: object) -> bool:
        if not isinstance(index, int) or index < 0:
            return False
        page = self._pages.get(index // PAGE)
        return page is not None and bool(page[index % PAGE >> 3] >> (index & 7) & 1)

    def add(self, index: int) -> None:
        if index < 0:
            raise ValueError(f"an IndexSet holds indices >= 0, not {index}")
        page = self._pages.get(index // PAGE)
        if page is None:
            page = self._pages[index // PAGE] = bytearray(PAGE // 8)
        byte, bit = index % PAGE >> 3, 1 << (index & 7)
        if not page[byte] & bit:
            page[byte] |= bit
            self._count += 1

    def update(self, indices: Iterable[int]) -> None:
        if isinstance(indices, range) and indices.step == 1 and indices.start >= 0:
            self._add_run(indices.start, indices.stop)  # a page at a time, no index visited
            return
        for index in indices:
            self.add(index)

    def _add_run(self, start: int, stop: int) -> None:
        while start < stop:
            number, low = divmod(start, PAGE)
            high = min(PAGE, low + stop - start)
            page = self._pages.setdefault(number, bytearray(PAGE // 8))
            bits = int.from_bytes(page, "little")  # bit k: index number * PAGE + k
            merged = bits | ((1 << high) - (1 << low))
            page[:] = merged.to_bytes(PAGE // 8, "little")
            self._count += merged.bit_count() - bits.bit_count()
            start += high - low

    def __isub__(self, other):  # type: ignore[override]
        if not isinstance(other, IndexSet):
            return super().__isub__(other)
        for number, theirs in other._pages.items():
            page = self._pages.get(number)
            if page is not None:
                bits = int.from_bytes(page, "little")
                kept = bits & ~int.from_bytes(theirs, "little")
                page[:] = kept.to_bytes(PAGE // 8, "little")
                self._count -= bits.bit_count() - kept.bit_count()
        return self

    def discard(self, index: int) -> None:
        if index in self:
            self._pages[index // PAGE][index % PAGE >> 3] &= ~(1 << (index & 7)) & 0xFF
            self._count -= 1

    def __len__(self) -> int:
        return self._count

    def copy(self) -> IndexSet:
        """An independent copy, page by page (no index visited)."""
        out = IndexSet()
        out._pages = {number: bytearray(page) for number, page in self._pages.items()}
        out._count = self._count
        return out

    def __iter__(self) -> Iterator[int]:
        """Ascending."""
        for number in sorted(self._pages):
            page, base = self._pages[number], number * PAGE
            for byte, bits in enumerate(page):
                while bits:
                    low = bits & -bits
                    yield base + byte * 8 + low.bit_length() - 1
                    bits ^= low

    def __repr__(self) -> str:
        return f"IndexSet({len(self)} indices)"


def _index_of(key: str) -> int | None:
    """The index whose ``sample_key`` is ``key``; None for any other string."""
    if len(key) == KEY_DIGITS and key.isascii() and key.isdigit():
        return int(key)
    return None


class KeySet(MutableSet[str]):
    def __init__(self, keys: Iterable[str] = ()):
        self._indices = IndexSet()
        self._other: set[str] = set()
        self.update(keys)

    def __contains__(self, key: object) -> bool:
        if not isinstance(key, str):
            return False
        index = _index_of(key)
        return index in self._indices if index is not None else key in self._other

    def add(self, key: str) -> None:
        index = _index_of(key)
        if index is not None:
            self._indices.add(index)
        else:
            self._other.add(key)

    def discard(self, key: str) -> None:
        index = _index_of(key)
        if index is not None:
            self._indices.discard(index)
        else:
            self._other.discard(key)

    def update(self, keys: Iterable[str]) -> None:
        for key in keys:
            self.add(key)

    def __len__(self) -> int:
        return len(self._indices) + len(self._other)

    def __iter__(self) -> Iterator[str]:
        """The canonical keys in index order, then the others."""
        yield from map(sample_key, self._indices)
        yield from self._other

    def __repr__(self) -> str:
        return f"KeySet({len(self)} keys)"
