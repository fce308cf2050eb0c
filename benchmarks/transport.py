"""The DataTransfer engine with no rendering: what one broker, 1, 2 or 4 writers and one
coordinator take, against the broker's raw rate for the same payloads (issue 43).

    .venv/bin/python benchmarks/transport.py            # both sets, 1/2/4 writers, 100/300/1000 workers
    .venv/bin/python benchmarks/transport.py --quick    # the flat set, 1 writer, 100 workers

Samples are recorded once (the default config at 640x480 and grasp_flat at 160x120, under
``benchmarks/results/transport/``) and replayed by simulated workers
(``datagen.pipeline.executors.simulated``): signed and framed as workers publish them, through
a Mosquitto broker this script starts, to ``datagen writer`` processes. Beside each engine run,
the raw rate: bare paho clients publishing payloads of the same sizes at QoS 1 through the same
broker to as many shared-subscription readers. Rates count from the first sample that is
durable (or received) to the last; CPU-seconds per sample are each role's own (/proc and the
writers' rusage). A simulated-worker run ends with its exact, verified count.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import resource
import secrets
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

import paho.mqtt.client as mqtt
from machine import cpu_model

from datagen.config import BuildConfig, load_config
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.connection import MqttConnection
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.topics import topics
from datagen.transport.wire import SECRET_ENV

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
TICK = os.sysconf("SC_CLK_TCK")
MAX_MESSAGE = 64 * 2**20
# In-flight samples per producer, as a worker's transfer.window: 64 of 1.5 MiB samples from
# each producer buried the broker (no answer to the coordinator's probe for 60 s, re-issues).
WINDOW = 8


def recorded_set(name: str, count: int, results: Path) -> Path:
    """A dataset of ``count`` samples of set ``name`` (built once, then reused)."""
    folder = results / "transport" / f"recorded-{name}-{count}"
    if not (folder / "manifest.json").is_file():
        base = BuildConfig() if name == "default" else load_config(REPO / "configs/grasp_flat.yaml")
        if name == "flat":
            base = base.replace(render=replace(base.render, width=160, height=120))
        config = base.replace(
            num_samples=count, output=replace(base.output, formats=("webdataset",))
        )
        print(f"recording {count} samples of the {name} set into {folder} ...", flush=True)
        run_build(config, folder, workers=2, overwrite=True)
    return folder


def payload_sizes(folder: Path) -> list[int]:
    """Bytes of each recorded sample's parts plus its wire header (~1 KiB)."""
    dataset = load(folder)
    return [sum(map(len, dataset.raw(i).values())) + 1024 for i in range(len(dataset))]


def cpu_s(pid: int) -> float:
    """utime + stime of a live process, seconds (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICK


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


class CpuWatch:
    """The last CPU time seen of each watched process, read every 0.2 s while it lives."""

    def __init__(self):
        self.pids: dict[int, str] = {}
        self.seen: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def watch(self, pid: int, role: str) -> None:
        self.pids[pid] = role

    def _loop(self) -> None:
        while not self._stop.wait(0.2):
            for pid in list(self.pids):
                self.seen[pid] = max(self.seen.get(pid, 0.0), cpu_s(pid))

    def by_role(self) -> dict[str, float]:
        self._stop.set()
        self._thread.join()
        roles: dict[str, float] = {}
        for pid, role in self.pids.items():
            roles[role] = roles.get(role, 0.0) + max(self.seen.get(pid, 0.0), cpu_s(pid))
        return roles


def engine(folder: Path, n: int, writers: int, workers: int, hosts: int, faults=None) -> dict:
    """A simulated-worker build of ``n`` samples replaying ``folder``, to ``writers`` writers;
    the dataset it writes (1.5 GB at 2000 default samples) is deleted once verified."""
    with tempfile.TemporaryDirectory(prefix="datagen-transport-") as out:
        return _engine_into(Path(out), folder, n, writers, workers, hosts, faults)


def _engine_into(out: Path, folder: Path, n, writers, workers, hosts, faults) -> dict:
    build_id, secret = secrets.token_hex(6), secrets.token_hex(32)
    base = BuildConfig()
    config = base.replace(
        num_samples=n,
        seed=5,
        output=replace(base.output, formats=("webdataset",)),
        transfer=replace(base.transfer, max_sample_mb=MAX_MESSAGE / 2**20 - 1),
        build=replace(base.build, worker_timeout_s=10.0),  # a hung worker is found in 10 s
    )
    cpu, times, rss = CpuWatch(), [], {}
    with ManagedBroker(BrokerSettings(max_message_bytes=MAX_MESSAGE)) as broker:
        cpu.watch(broker.pid, "broker")
        env = os.environ | {"DATAGEN_BROKER_URL": broker.url, SECRET_ENV: secret}
        procs = []
        for k in range(writers):
            cmd = [sys.executable, "-m", "datagen.cli", "writer", "--build-id", build_id]
            cmd += ["--out", str(out), "--writer-id", f"w{k}", "--shard-size", "512"]
            procs.append(subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL))

        def observe(event, details):
            if event == "worker" and "pid" in details:
                cpu.watch(details["pid"], "producer")

        def progress(done, total):
            times.append(time.monotonic())
            for mark in (max(1, total // 10), total):
                if done >= mark and mark not in rss:
                    rss[mark] = round(rss_mb(), 1)

        options = {
            "recorded": str(folder),
            "faults": faults or {},
            "hosts": hosts,
            "window": WINDOW,
        }
        os.environ[SECRET_ENV] = secret
        before = resource.getrusage(resource.RUSAGE_SELF)
        try:
            run_build(
                config,
                out,
                workers,
                broker_url=broker.url,
                writers=[f"w{k}" for k in range(writers)],
                build_id=build_id,
                executor="simulated",
                executor_options=options,
                observer=observe,
                on_progress=progress,
            )
        finally:
            os.environ.pop(SECRET_ENV, None)
        after = resource.getrusage(resource.RUSAGE_SELF)
        writer_cpu = 0.0
        for proc in procs:
            _, status, usage = os.wait4(proc.pid, 0)
            proc.returncode = os.waitstatus_to_exitcode(status)
            writer_cpu += usage.ru_utime + usage.ru_stime
        roles = cpu.by_role()
    roles["writer"] = writer_cpu
    roles["coordinator"] = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    report = verify(out)
    exact = len(load(out)) == n == report.get("samples", n)
    rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0
    return {
        "samples": n,
        "writers": writers,
        "workers": workers,
        "samples_per_s": round(rate, 1),
        "cpu_ms_per_sample": {role: round(1000 * s / n, 3) for role, s in sorted(roles.items())},
        "coordinator_rss_mb": rss,
        "verified": exact,
    }


def _subscriber(url, topic, conn) -> None:
    """Counts what it receives; sends (first, last, count) every 0.2 s until told to stop."""
    state = {"count": 0, "first": 0.0, "last": 0.0}

    def on_message(message):
        now = time.monotonic()
        state["first"] = state["first"] or now
        state["last"], state["count"] = now, state["count"] + 1

    name = f"raw-sub-{secrets.token_hex(4)}"
    mqtt_conn = MqttConnection(url, name, subscriptions=[(topic, 1)], on_message=on_message)
    try:
        conn.send("ready")
        while not conn.poll(0.2):
            conn.send((state["first"], state["last"], state["count"]))
    finally:
        mqtt_conn.close()


def _publisher(url, topic, sizes, count, conn) -> None:
    """A bare paho client: ``count`` QoS 1 publishes, ``WINDOW`` in flight (a host's)."""
    payloads = [os.urandom(size) for size in sizes]
    address = parse_broker_url(url)
    client = mqtt.Client(
        mqtt.CallbackAPIVersion.VERSION2,
        client_id=f"raw-pub-{secrets.token_hex(4)}",
        protocol=mqtt.MQTTv5,
    )
    client.username_pw_set(address.username, address.password)
    client.max_inflight_messages_set(WINDOW)
    client.max_queued_messages_set(0)
    client.connect(address.host, address.port)
    client.loop_start()
    try:
        conn.recv()  # go
        infos = [client.publish(topic, payloads[i % len(payloads)], qos=1) for i in range(count)]
        for info in infos:
            info.wait_for_publish(600)
        conn.send("sent")
    finally:
        client.disconnect()
        client.loop_stop()


def _start(context, target, *args):
    ours, theirs = context.Pipe()
    process = context.Process(target=target, args=(*args, theirs))
    process.start()
    return process, ours


def raw(sizes: list[int], n: int, publishers: int, readers: int) -> dict:
    """The broker's rate for ``n`` payloads of ``sizes`` from ``publishers`` bare QoS 1
    clients to ``readers`` shared-subscription readers."""
    context = mp.get_context("spawn")
    with ManagedBroker(BrokerSettings(max_message_bytes=MAX_MESSAGE)) as broker:
        cpu = CpuWatch()
        cpu.watch(broker.pid, "broker")
        names = topics(secrets.token_hex(6))
        subs = [
            _start(context, _subscriber, broker.url, names.shared_samples) for _ in range(readers)
        ]
        for _, conn in subs:
            conn.recv()  # subscribed
        pubs = []
        for k in range(publishers):
            count = n // publishers + (k < n % publishers)
            pubs.append(_start(context, _publisher, broker.url, names.samples, sizes, count))
        time.sleep(1.0)  # connected
        for _, conn in pubs:
            conn.send("go")
        latest = [(0.0, 0.0, 0)] * readers
        deadline = time.monotonic() + 600
        while sum(s[2] for s in latest) < n and time.monotonic() < deadline:
            for k, (_, conn) in enumerate(subs):
                while conn.poll(0.05):
                    latest[k] = conn.recv()
        for _, conn in subs:
            conn.send("stop")
        for _, conn in pubs:
            conn.recv()  # every publish acknowledged
        for process, _ in [*subs, *pubs]:
            process.join(timeout=30)
        roles = cpu.by_role()
    got = sum(s[2] for s in latest)
    first = min(s[0] for s in latest if s[2])
    last = max(s[1] for s in latest)
    return {
        "samples_per_s": round((got - 1) / (last - first), 1),
        "received": got,
        "cpu_ms_per_sample": {r: round(1000 * s / n, 3) for r, s in roles.items()},
    }


def _names(text: str | None) -> list[str]:
    return [name for name in (text or "").split(",") if name]


def _se(values: list[float]) -> float:
    return statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else 0.0


def _mean_se(values: list[float]) -> str:
    return f"{statistics.mean(values):.1f} ± {_se(values):.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the flat set, 1 writer, 100 workers")
    parser.add_argument(
        "--samples", type=int, default=None, help="samples per run (the default set: a third)"
    )
    parser.add_argument(
        "--out", type=Path, default=RESULTS, help="recorded sets and results (benchmarks/results)"
    )
    parser.add_argument("--sets", default=None, help="comma-separated: default,flat")
    parser.add_argument("--writers", default=None, help="comma-separated writer counts: 1,2,4")
    parser.add_argument("--scaling", default=None, help="simulated worker counts: 100,300,1000")
    parser.add_argument("--repeats", type=int, default=1, help="engine and raw runs per point")
    args = parser.parse_args()
    quick = args.quick
    n = args.samples or (600 if quick else 3000)
    sets = _names(args.sets) or (["flat"] if quick else ["default", "flat"])
    writer_counts = [int(w) for w in _names(args.writers)] or ([1] if quick else [1, 2, 4])
    worker_counts = [int(w) for w in _names(args.scaling)] or ([100] if quick else [100, 300, 1000])
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; {n} samples per run", flush=True)
    results: dict = {"machine": cpu_model(), "cores": os.cpu_count(), "samples": n, "sets": {}}
    for name in sets:
        folder = recorded_set(name, 8 if quick else 16, args.out)
        sizes = payload_sizes(folder)
        mean_mb = statistics.mean(sizes) / 2**20
        print(f"set {name}: {len(sizes)} recorded samples, mean {mean_mb:.3f} MiB on the wire")
        runs, count = [], n if name == "flat" else max(100, n // 3)  # 1.5 MiB each: a third
        for writers in writer_counts:
            ratios, rates, raw_rates = [], [], []
            for _ in range(args.repeats):  # engine and raw side by side, alternating
                e = engine(folder, count, writers, workers=32, hosts=2)
                r = raw(sizes, count, publishers=2, readers=writers)
                ratios.append(e["samples_per_s"] / r["samples_per_s"])
                rates.append(e["samples_per_s"])
                raw_rates.append(r["samples_per_s"])
                print(
                    f"  {writers} writer(s): engine {e['samples_per_s']} samples/s "
                    f"({e['samples_per_s'] * mean_mb:.1f} MiB/s), raw {r['samples_per_s']} "
                    f"samples/s; CPU ms/sample {e['cpu_ms_per_sample']}; verified {e['verified']}"
                )
                runs.append({"engine": e, "raw": r, "engine_over_raw": round(ratios[-1], 3)})
            print(
                f"  {writers} writer(s) over {args.repeats} run(s): engine {_mean_se(rates)} "
                f"samples/s, raw {_mean_se(raw_rates)} samples/s",
                flush=True,
            )
            print(f"  engine ÷ raw: {statistics.mean(ratios):.2f} ± {_se(ratios):.2f}", flush=True)
        results["sets"][name] = {"mean_mib": round(mean_mb, 4), "runs": runs}
    flat = recorded_set("flat", 8 if quick else 16, args.out)
    faults = {"render_s": (0.0, 0.05), "crash": 0.002, "hang": 0.001, "duplicate": 0.01}
    scaling = []
    for workers in worker_counts:
        e = engine(flat, n, 1, workers=workers, hosts=2, faults=faults)
        per = e["cpu_ms_per_sample"]["coordinator"]
        print(
            f"simulated workers {workers}: coordinator {per} ms CPU/sample, RSS MB at "
            f"10%/100% {e['coordinator_rss_mb']}; {e['samples']} of {n} samples, "
            f"verified: {e['verified']}",
            flush=True,
        )
        scaling.append(e)
    if len(scaling) > 1:
        ratio = (
            scaling[-1]["cpu_ms_per_sample"]["coordinator"]
            / scaling[0]["cpu_ms_per_sample"]["coordinator"]
        )
        print(
            f"coordinator CPU/sample at {worker_counts[-1]} ÷ at {worker_counts[0]} workers: {ratio:.2f}"
        )
    results["simulated"] = scaling
    out = args.out / ("transport_quick.json" if quick else "transport.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2))
    print(f"results: {out}")


if __name__ == "__main__":
    main()
