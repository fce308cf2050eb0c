"""The latency histogram: percentiles within one bin of the true ones, constant memory, and
the schedule measuring published -> acked with the times it is given."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.pipeline.latency import BINS_PER_DECADE, LatencyHistogram
from datagen.pipeline.schedule import Schedule


def test_percentiles_are_within_one_bin_above_the_true_ones():
    rng = np.random.default_rng(0)
    seconds = rng.lognormal(mean=np.log(0.05), sigma=1.0, size=20_000)
    histogram = LatencyHistogram()
    for s in seconds:
        histogram.add(float(s))
    bin_ratio = 10 ** (1 / BINS_PER_DECADE)
    for p in (50, 90, 99):
        true = float(np.percentile(seconds, p))
        assert true * 0.999 <= histogram.percentile(p) <= true * bin_ratio * 1.001, p
    assert histogram.summary()["max_s"] == pytest.approx(seconds.max(), abs=1e-4)
    assert len(histogram.counts) == BINS_PER_DECADE * 6 + 1  # whatever was added


def test_extremes_land_in_the_end_bins_and_empty_is_zero():
    histogram = LatencyHistogram()
    assert histogram.percentile(50) == 0.0 and histogram.summary()["samples"] == 0
    for s in (0.0, 1e-6, 5e4):
        histogram.add(s)
    assert histogram.counts[0] == 2 and histogram.counts[-1] == 1
    assert histogram.percentile(100) == 5e4


def test_the_schedule_measures_published_to_acked():
    schedule = Schedule(range(3), ack_timeout_s=60)
    schedule.add_worker(0)
    schedule.next_for(0)
    schedule.on_published(0, 0, now=10.0)
    schedule.on_published(0, 1, now=10.5)
    schedule.on_acked(0, now=10.2)
    schedule.on_acked(1, now=11.5)
    schedule.on_acked(2, now=12.0)  # its publishing was never reported: not measured
    summary = schedule.latency.summary()
    assert summary["samples"] == 2 and summary["max_s"] == pytest.approx(1.0)
    assert 0.2 <= summary["p50_s"] <= 0.2 * 10 ** (1 / BINS_PER_DECADE)
