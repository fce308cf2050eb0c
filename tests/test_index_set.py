"""IndexSet and KeySet behave as Python sets of the same values, in about a bit per index."""

from __future__ import annotations

import random
import sys

import pytest

from datagen.index_set import PAGE, IndexSet, KeySet
from datagen.sample import sample_key


def test_an_index_set_is_a_set_under_random_adds_and_discards():
    rng = random.Random(0)
    ours, theirs = IndexSet(), set()
    for _ in range(20_000):
        index = rng.choice([rng.randrange(3 * PAGE), rng.randrange(10**9)])
        if rng.random() < 0.7:
            ours.add(index)
            theirs.add(index)
        else:
            ours.discard(index)
            theirs.discard(index)
    assert len(ours) == len(theirs) and list(ours) == sorted(theirs)
    assert all(i in ours for i in theirs) and -1 not in ours and "3" not in ours
    assert {5, 7} <= IndexSet([5, 7, 9]) and set(IndexSet([1]) | {2}) == {1, 2}


def test_a_stray_large_index_costs_one_page_not_a_bitmap_up_to_it():
    indices = IndexSet([3, 999_999_999])
    assert list(indices) == [3, 999_999_999]
    assert sum(len(page) for page in indices._pages.values()) == 2 * PAGE // 8
    with pytest.raises(ValueError, match=">= 0"):
        indices.add(-1)


def test_a_key_set_holds_canonical_keys_as_bits_and_others_as_strings():
    keys = KeySet(sample_key(i) for i in range(100_000))
    keys.update(["odd-key", "12", "0000000x5"])
    assert len(keys) == 100_003 and "odd-key" in keys and "000000012" not in {"12"}
    assert sample_key(99_999) in keys and sample_key(100_000) not in keys and 12 not in keys
    keys.discard(sample_key(5))
    keys.discard("12")
    assert sample_key(5) not in keys and "12" not in keys and len(keys) == 100_001
    assert list(keys)[:2] == [sample_key(0), sample_key(1)]
    memory = sum(sys.getsizeof(page) for page in keys._indices._pages.values())
    assert memory < 20_000  # 100,000 keys as strings in a set: some 10 MB
