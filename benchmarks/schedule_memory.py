"""What the coordinator's schedule holds for a build of N samples before the first is issued,
and what one resumed with half of them durable holds (issue 43: nothing in the control plane
may grow with the build).

    .venv/bin/python benchmarks/schedule_memory.py
    .venv/bin/python benchmarks/schedule_memory.py --sizes 100000 1000000 10000000

For each N: the Python heap the schedule holds once made (tracemalloc: current and peak while
making it) and the seconds it took, made as the coordinator makes it (every index less the
durable ones). Pure Python, no broker, no process.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

from machine import cpu_model

from datagen.index_set import IndexSet
from datagen.pipeline.schedule import Schedule


def held(total: int, durable: IndexSet) -> tuple[float, float, float]:
    """(MB held, MB peak, seconds) of the schedule of ``total`` samples less ``durable``."""
    tracemalloc.start()
    started = time.perf_counter()
    to_make = IndexSet(range(total))
    to_make -= durable
    schedule = Schedule(to_make, ack_timeout_s=60.0)
    seconds = time.perf_counter() - started
    current, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(schedule.remaining) == total - len(durable)
    return current / 1e6, peak / 1e6, seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    args = parser.parse_args()
    print(cpu_model())
    for total in args.sizes:
        fresh = held(total, IndexSet())
        resumed = held(total, IndexSet(range(0, total, 2)))
        for name, (current, peak, seconds) in (("fresh", fresh), ("half durable", resumed)):
            print(
                f"{total:>10,} samples, {name:12s}: holds {current:8.2f} MB "
                f"(peak {peak:8.2f} MB), made in {seconds:.3f} s"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
