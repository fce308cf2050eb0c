"""What one sample costs each step of the engine, timed in one process on the recorded
samples: the worker's signing and framing, then the writer's checks and keeping, in the order
the writer does them. Their sum is the most one core of a writer can keep per second; the
steps a bare broker client does not do (signing, checking, hashing, writing to disk) are
where the engine's rate parts from the raw one."""

from __future__ import annotations

import secrets
import tempfile
import time
from pathlib import Path

from datagen.dataset.loader import load
from datagen.safe_json import loads_bounded
from datagen.sample import Sample
from datagen.transport.run_binding import RunBinding
from datagen.transport.wire import decode_sample, encode_sample
from datagen.writer.shard_writer import ShardWriter

BATCH = 8  # samples made durable by one fsync: the writer's batches at the default set's rate


def sample_steps(folder: Path, count: int = 300) -> dict[str, float]:
    """Milliseconds per sample of each step over ``count`` samples replayed from ``folder``,
    one sample at a time through every step (as memory is reused in a worker and a writer)."""
    dataset = load(folder)
    recorded = [dataset.raw(i) for i in range(len(dataset))]
    dataset.close()
    secret, run = secrets.token_bytes(32), RunBinding(secrets.token_hex(16), "0" * 64, 0)
    steps = {
        "sign and frame (worker)": 0.0,
        "check MAC, split (writer)": 0.0,
        "parse metadata (writer)": 0.0,
        "tar, digests, write (writer)": 0.0,
        f"fsync and journal, a batch of {BATCH} (writer)": 0.0,
    }
    names = list(steps)
    with tempfile.TemporaryDirectory(prefix="datagen-steps-") as out:
        shards = ShardWriter(Path(out), "0", 1000, 0)
        for i in range(count):
            times = [time.perf_counter()]
            payload = encode_sample("b", Sample(i, recorded[i % len(recorded)]), secret, run)
            times.append(time.perf_counter())
            sample = decode_sample(payload, None, secret, run)[1]
            times.append(time.perf_counter())
            loads_bounded(sample.parts["json"], what="json")
            times.append(time.perf_counter())
            shards.write(sample)
            times.append(time.perf_counter())
            if i % BATCH == BATCH - 1:
                shards.flush_durable()
            times.append(time.perf_counter())
            for name, begun, ended in zip(names, times, times[1:], strict=False):
                steps[name] += ended - begun
        shards.close()
    return {name: round(1000 * seconds / count, 3) for name, seconds in steps.items()}
