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


def test_a_run_and_a_set_difference_go_a_page_at_a_time_and_agree_with_sets():
    """``IndexSet(range(...))`` and ``-=`` with another IndexSet work on whole pages; they give
    what adding and discarding one index at a time gives, across page edges."""
    rng = random.Random(1)
    for _ in range(200):
        start = rng.randrange(3 * PAGE)
        stop = start + rng.choice(
            [0, 1, 7, 8, 9, PAGE - 1, PAGE, PAGE + 1, rng.randrange(3 * PAGE)]
        )
        ours = IndexSet(rng.randrange(4 * PAGE) for _ in range(50))
        theirs = set(ours)
        ours.update(range(start, stop))
        theirs.update(range(start, stop))
        assert len(ours) == len(theirs) and list(ours) == sorted(theirs)
        other = IndexSet(rng.randrange(5 * PAGE) for _ in range(rng.randrange(5000)))
        ours -= other
        theirs -= set(other)
        assert len(ours) == len(theirs) and list(ours) == sorted(theirs)
    ours = IndexSet([1, 2, 3])
    ours -= {2, 10}  # any other set: one at a time
    assert list(ours) == [1, 3] and len(ours) == 2
    everything = IndexSet(range(10**6))
    assert len(everything) == 10**6 and sum(len(p) for p in everything._pages.values()) < 140_000
