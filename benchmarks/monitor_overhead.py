"""What watching a build costs it: the same build with and without the live monitor, in one run.

    .venv/bin/python benchmarks/monitor_overhead.py                  # 60 samples, 2 rounds
    .venv/bin/python benchmarks/monitor_overhead.py --samples 20 --rounds 1   # quick

Builds ``configs/grasp_tabletop.yaml`` (640x480) into a temporary directory with ``run_build``,
alternately (A B B A, B A A B, ..., so both sides see the same drift in machine load and
take each place in a round equally often):

- **without**: ``$DATAGEN_LIVE=0``: no live status, no previews, no WebSockets listener;
- **with**: the live status (~1 Hz), the workers' previews (one JPEG a second each) and the
  build's broker with its WebSockets listener, and a subscriber to everything the page reads
  (``datagen/+/live/#``, over WebSockets as the monitor user, as the page does).

Throughput is durable samples per second from the first durable sample to the last (start-up
left out: it is the same on both sides). On a machine shared with other jobs that figure moves
by tens of percent from run to run, so each run also reports the CPU seconds per sample that
the build took in all its processes (this one, workers, writer, Mosquitto: ``getrusage``),
which the neighbours disturb far less. Prints both for each run, the medians, and the costs
``1 - with/without`` (throughput) and ``with/without - 1`` (CPU); writes them with the load
average to ``benchmarks/results/monitor_overhead.json`` (git-ignored).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import tempfile
import threading
import time
from pathlib import Path

import paho.mqtt.client as mqtt

from datagen.config import load_config
from datagen.pipeline.live_status import LIVE_ENV
from datagen.pipeline.run import run_build

REPO = Path(__file__).resolve().parents[1]


class PageStandIn:
    """Subscribes to every live topic over WebSockets as the monitor user; counts messages."""

    def __init__(self):
        self.client: mqtt.Client | None = None
        self.messages = 0

    def __call__(self, broker) -> None:  # run_build's ``monitor`` callback
        c = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5, transport="websockets")  # fmt: skip
        c.username_pw_set(broker.monitor_username, broker.monitor_password)
        c.on_connect = lambda c, u, f, rc, p: c.subscribe("datagen/+/live/#")
        c.on_message = lambda c, u, m: self._count()
        c.connect("127.0.0.1", broker.websockets_port)
        c.loop_start()
        self.client = c

    def _count(self) -> None:
        self.messages += 1

    def close(self) -> None:
        if self.client is not None:
            self.client.disconnect()
            self.client.loop_stop()


def cpu_seconds() -> float:
    """CPU time of this process and of its children that have ended (a build's all have)."""
    me, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))  # fmt: skip
    return me.ru_utime + me.ru_stime + children.ru_utime + children.ru_stime


def one_build(config, workers: int, watched: bool) -> tuple[float, float, int]:
    """(durable samples/s from the first durable sample to the last, CPU seconds per sample,
    live messages seen)."""
    os.environ[LIVE_ENV] = "1" if watched else "0"
    times: dict[int, float] = {}
    lock = threading.Lock()

    def on_progress(done: int, total: int) -> None:
        with lock:
            times.setdefault(done, time.perf_counter())

    page = PageStandIn() if watched else None
    cpu = cpu_seconds()
    with tempfile.TemporaryDirectory(prefix="monitor-overhead-") as out:
        try:
            run_build(config, out, workers, on_progress=on_progress, monitor=page)
        finally:
            if page is not None:
                page.close()
    cpu = (cpu_seconds() - cpu) / config.num_samples
    first = min(t for d, t in times.items() if d >= 1)
    last = times[config.num_samples]
    return (config.num_samples - 1) / (last - first), cpu, page.messages if page else 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=2, help="rounds of 4 builds: A B B A, then B A A B, ...")  # fmt: skip
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    config = load_config(REPO / "configs" / "grasp_tabletop.yaml").replace(num_samples=args.samples)
    rates: dict[str, list[float]] = {"without": [], "with": []}
    cpus: dict[str, list[float]] = {"without": [], "with": []}
    seen = []
    for round_ in range(args.rounds):
        for watched in (
            (False, True, True, False) if round_ % 2 == 0 else (True, False, False, True)
        ):
            rate, cpu, messages = one_build(config, args.workers, watched)
            side = "with" if watched else "without"
            rates[side].append(rate)
            cpus[side].append(cpu)
            seen += [messages] if watched else []
            print(f"{side:>8} monitor: {rate:.3f} samples/s, {cpu:.3f} CPU s/sample" + (f" ({messages} live messages received)" if watched else ""), flush=True)  # fmt: skip
    without, with_ = statistics.median(rates["without"]), statistics.median(rates["with"])
    cost = 1 - with_ / without
    cpu_without, cpu_with = statistics.median(cpus["without"]), statistics.median(cpus["with"])
    cpu_cost = cpu_with / cpu_without - 1
    print(f"median: without {without:.3f} samples/s, with {with_:.3f} samples/s; ratio {with_ / without:.3f} (cost {cost:+.1%})")  # fmt: skip
    print(f"median CPU per sample: without {cpu_without:.3f} s, with {cpu_with:.3f} s (cost {cpu_cost:+.1%})")  # fmt: skip
    results = REPO / "benchmarks" / "results"
    results.mkdir(parents=True, exist_ok=True)
    record = {"samples": args.samples, "workers": args.workers, "rates": rates,
              "median_without": without, "median_with": with_, "cost": cost,
              "cpu_s_per_sample": cpus, "cpu_cost": cpu_cost,
              "live_messages": seen, "loadavg": os.getloadavg()}  # fmt: skip
    (results / "monitor_overhead.json").write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main()
