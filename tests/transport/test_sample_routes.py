"""Which broker carries a sample: a function of its index alone, spreading consecutive samples
evenly, so a re-issued sample reaches the writer set that may already hold it."""

from __future__ import annotations

from collections import Counter

import pytest

from datagen.transport.sample_routes import RoutedPublisher, broker_for


@pytest.mark.parametrize("brokers", [1, 2, 3, 7])
def test_every_index_has_one_broker_and_consecutive_samples_spread_evenly(brokers):
    counts = Counter(broker_for(i, brokers) for i in range(1000 * brokers))
    assert set(counts) == set(range(brokers)) and set(counts.values()) == {1000}
    assert all(broker_for(i, brokers) == broker_for(i, brokers) for i in range(50))


def test_no_broker_is_an_error_not_a_division_by_zero():
    with pytest.raises(ValueError, match="at least one sample broker"):
        broker_for(3, 0)
    with pytest.raises(ValueError, match="at least one sample broker URL"):
        RoutedPublisher([], "b", "c")
