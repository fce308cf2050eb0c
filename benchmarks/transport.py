"""The DataTransfer engine with no rendering: what one broker, 1, 2 or 4 writers and one
coordinator take, against the broker's raw rate for the same payloads; samples spread over one
and two brokers; and the memory of every role over a long build (issue 43).

    .venv/bin/python benchmarks/transport.py            # everything below, full size
    .venv/bin/python benchmarks/transport.py --quick    # the flat set, small: every part once

Samples are recorded once (the default config at 640x480 and grasp_flat at 160x120, under
``benchmarks/results/transport/``) and replayed by simulated workers
(``datagen.pipeline.executors.simulated``): signed and framed as workers publish them, through
a Mosquitto broker this script starts, to ``datagen writer`` processes. Beside each engine run,
the raw rate: bare paho clients publishing payloads of the same sizes at QoS 1 through the same
broker to as many shared-subscription readers. Rates count from the first sample that is
durable (or received) to the last; CPU-seconds per sample are each role's own (/proc and the
writers' rusage); latency runs from a worker's report that it published a sample to the
writer's ack (``datagen.pipeline.latency``). With two brokers, sample i goes to broker i mod 2,
each with its own writers (``--sample-broker``). The long run records the resident memory of
each role at every tenth of the build. A simulated-worker run ends with its exact, verified
count.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import secrets
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from machine import cpu_model
from transfer_engine.process_watch import CpuWatch, rss_mb
from transfer_engine.raw_broker import MAX_MESSAGE, WINDOW, raw
from transfer_engine.sample_steps import sample_steps

from datagen.config import BuildConfig, load_config
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build
from datagen.pipeline.worker import die_with_parent
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.wire import SECRET_ENV

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
FAULTS = {"render_s": (0.0, 0.05), "crash": 0.002, "hang": 0.001, "duplicate": 0.01}


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


def engine(
    folder: Path, n: int, writers: int, workers: int, hosts: int, faults=None, brokers: int = 1
) -> dict:
    """A simulated-worker build of ``n`` samples replaying ``folder``, to ``writers`` writers
    spread over ``brokers`` brokers (writer k takes broker k mod ``brokers``'s samples); the
    dataset it writes (1.5 GB at 2000 default samples) is deleted once verified."""
    with tempfile.TemporaryDirectory(prefix="datagen-transport-") as out:
        return _engine_into(Path(out), folder, n, writers, workers, hosts, faults, brokers)


def _engine_into(out: Path, folder: Path, n, writers, workers, hosts, faults, brokers) -> dict:
    build_id, secret = secrets.token_hex(6), secrets.token_hex(32)
    base = BuildConfig()
    config = base.replace(
        num_samples=n,
        seed=5,
        output=replace(base.output, formats=("webdataset",)),
        transfer=replace(base.transfer, max_sample_mb=MAX_MESSAGE / 2**20 - 1),
        build=replace(base.build, worker_timeout_s=10.0),  # a hung worker is found in 10 s
    )
    cpu, rss = CpuWatch(), {}
    # first and last progress report, and how many: a list of times grew 32 B a sample (what the
    # coordinator's memory was seen to grow by over 100,000 samples, traced with tracemalloc)
    times = {"first": 0.0, "last": 0.0, "reports": 0}
    with contextlib.ExitStack() as stack:
        started = [
            stack.enter_context(
                ManagedBroker(
                    BrokerSettings(max_message_bytes=MAX_MESSAGE), preexec_fn=die_with_parent
                )
            )
            for _ in range(brokers)
        ]
        urls = [broker.url for broker in started]
        for broker in started:
            cpu.watch(broker.pid, "broker")
        env = os.environ | {"DATAGEN_BROKER_URL": urls[0], SECRET_ENV: secret}
        procs = []
        for k in range(writers):
            cmd = [sys.executable, "-m", "datagen.cli", "writer", "--build-id", build_id]
            cmd += ["--out", str(out), "--writer-id", f"w{k}", "--shard-size", "512"]
            sample_env = {"DATAGEN_SAMPLE_BROKER_URL": urls[k % brokers]}
            procs.append(  # gone with this script, however it ends
                subprocess.Popen(
                    cmd,
                    cwd=REPO,
                    env=env | sample_env,
                    stdout=subprocess.DEVNULL,
                    preexec_fn=die_with_parent,
                )
            )
            cpu.watch(procs[-1].pid, "writer")

        def observe(event, details):
            if event == "worker" and "pid" in details:
                cpu.watch(details["pid"], "producer")

        def progress(done, total):
            now = time.monotonic()
            times["first"] = times["first"] or now
            times["last"], times["reports"] = now, times["reports"] + 1
            mark = done * 10 // total * total // 10  # every tenth of the build
            if mark and mark not in rss:
                rss[mark] = cpu.rss_by_role() | {"coordinator": round(rss_mb(), 1)}

        options = {
            "recorded": str(folder),
            "faults": faults or {},
            "hosts": hosts,
            "window": WINDOW,
        }
        os.environ[SECRET_ENV] = secret
        before = resource.getrusage(resource.RUSAGE_SELF)
        try:
            result = run_build(
                config,
                out,
                workers,
                broker_url=urls[0],
                sample_broker_urls=urls if brokers > 1 else None,
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
    span = times["last"] - times["first"]
    rate = (times["reports"] - 1) / span if span > 0 else 0.0
    return {
        "samples": n,
        "writers": writers,
        "brokers": brokers,
        "workers": workers,
        "samples_per_s": round(rate, 1),
        "latency": result.latency,
        "cpu_ms_per_sample": {role: round(1000 * s / n, 3) for role, s in sorted(roles.items())},
        "rss_mb": {str(mark): by_role for mark, by_role in sorted(rss.items())},
        "verified": exact,
    }


def _latency(e: dict) -> str:
    lat = e["latency"]
    return f"latency p50/p90/p99 {lat['p50_s']}/{lat['p90_s']}/{lat['p99_s']} s"


def _names(text: str | None) -> list[str]:
    return [name for name in (text or "").split(",") if name]


def _se(values: list[float]) -> float:
    return statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else 0.0


def _mean_se(values: list[float]) -> str:
    return f"{statistics.mean(values):.1f} ± {_se(values):.1f}"


def print_steps(steps: dict[str, float]) -> dict[str, float]:
    print("  per sample, each step timed alone in one process:")
    for name, ms in steps.items():
        print(f"    {name}: {ms:.2f} ms")
    writer = sum(ms for name, ms in steps.items() if "(writer)" in name)
    print(f"    the writer's steps: {writer:.2f} ms, at most {1000 / writer:.0f} samples/s a core")
    return steps


def compare_writers(folder: Path, count: int, writers: int, repeats: int, mean_mb: float):
    """Engine and raw side by side, alternating, ``repeats`` times: (runs, ratios)."""
    runs, ratios, rates, raw_rates = [], [], [], []
    sizes = payload_sizes(folder)
    for _ in range(repeats):
        e = engine(folder, count, writers, workers=32, hosts=2)
        r = raw(sizes, count, publishers=2, readers=writers)
        ratios.append(e["samples_per_s"] / r["samples_per_s"])
        rates.append(e["samples_per_s"])
        raw_rates.append(r["samples_per_s"])
        print(
            f"  {writers} writer(s): engine {e['samples_per_s']} samples/s "
            f"({e['samples_per_s'] * mean_mb:.1f} MiB/s), raw {r['samples_per_s']} "
            f"samples/s; {_latency(e)}; CPU ms/sample {e['cpu_ms_per_sample']}; "
            f"verified {e['verified']}",
            flush=True,
        )
        runs.append({"engine": e, "raw": r, "engine_over_raw": round(ratios[-1], 3)})
    print(
        f"  {writers} writer(s) over {repeats} run(s): engine {_mean_se(rates)} "
        f"samples/s, raw {_mean_se(raw_rates)} samples/s",
        flush=True,
    )
    print(f"  engine ÷ raw: {statistics.mean(ratios):.2f} ± {_se(ratios):.2f}", flush=True)
    return runs


def compare_brokers(folder: Path, count: int, writers: int, repeats: int) -> dict:
    """The same build through one broker and through two (``writers`` in all, each side)."""
    rates: dict[int, list[float]] = {1: [], 2: []}
    runs = []
    for _ in range(repeats):
        for brokers in (1, 2):
            e = engine(folder, count, writers, workers=32, hosts=2, brokers=brokers)
            rates[brokers].append(e["samples_per_s"])
            runs.append(e)
            print(
                f"  {brokers} broker(s), {writers} writers: {e['samples_per_s']} samples/s; "
                f"{_latency(e)}; CPU ms/sample {e['cpu_ms_per_sample']}; "
                f"{e['samples']} of {count} samples, verified: {e['verified']}",
                flush=True,
            )
    ratios = [two / one for one, two in zip(rates[1], rates[2], strict=True)]
    print(
        f"  two brokers ÷ one: {statistics.mean(ratios):.2f} ± {_se(ratios):.2f} "
        f"({os.cpu_count()} cores for brokers, writers, producers and coordinator)",
        flush=True,
    )
    return {"runs": runs, "two_over_one": round(statistics.mean(ratios), 3)}


def long_run(folder: Path, n: int) -> dict:
    """A long simulated build: the resident memory of every role at each tenth of it."""
    e = engine(folder, n, 1, workers=100, hosts=2, faults=FAULTS)
    marks = e["rss_mb"]
    first, last = marks[min(marks, key=int)], marks[max(marks, key=int)]
    print(f"long run: {e['samples']} samples, verified: {e['verified']}; {_latency(e)}")
    for role in sorted(last):
        print(
            f"  {role} RSS MB at 10%/100%: {first.get(role)} / {last[role]} "
            f"({last[role] - first.get(role, 0.0):+.1f})",
            flush=True,
        )
    return e


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the flat set, small: each part once")
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
    parser.add_argument(
        "--long", type=int, default=None, help="samples of the memory run (default 100000)"
    )
    parser.add_argument(
        "--parts",
        default="writers,brokers,scaling,long",
        help="which parts to run (comma-separated; default: all)",
    )
    args = parser.parse_args()
    quick, parts = args.quick, set(_names(args.parts))
    n = args.samples or (600 if quick else 3000)
    sets = _names(args.sets) or (["flat"] if quick else ["default", "flat"])
    writer_counts = [int(w) for w in _names(args.writers)] or ([1] if quick else [1, 2, 4])
    worker_counts = [int(w) for w in _names(args.scaling)] or ([100] if quick else [100, 300, 1000])
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; {n} samples per run", flush=True)
    results: dict = {"machine": cpu_model(), "cores": os.cpu_count(), "samples": n, "sets": {}}
    for name in sets:
        folder = recorded_set(name, 8 if quick else 16, args.out)
        mean_mb = statistics.mean(payload_sizes(folder)) / 2**20
        print(f"set {name}: mean {mean_mb:.3f} MiB on the wire")
        count = n if name == "flat" else max(100, n // 3)  # 1.5 MiB each: a third
        entry: dict = {"mean_mib": round(mean_mb, 4)}
        if "writers" in parts:
            entry["steps_ms"] = print_steps(sample_steps(folder, 60 if quick else 300))
            entry["runs"] = [
                run
                for writers in writer_counts
                for run in compare_writers(folder, count, writers, args.repeats, mean_mb)
            ]
        if "brokers" in parts:
            entry["brokers"] = compare_brokers(folder, count, 2, args.repeats)
        results["sets"][name] = entry
    flat = recorded_set("flat", 8 if quick else 16, args.out)
    if "scaling" in parts:
        scaling = []
        for workers in worker_counts:
            e = engine(flat, n, 1, workers=workers, hosts=2, faults=FAULTS)
            per = e["cpu_ms_per_sample"]["coordinator"]
            print(
                f"simulated workers {workers}: coordinator {per} ms CPU/sample; {_latency(e)}; "
                f"{e['samples']} of {n} samples, verified: {e['verified']}",
                flush=True,
            )
            scaling.append(e)
        if len(scaling) > 1:
            first, last = (e["cpu_ms_per_sample"]["coordinator"] for e in (scaling[0], scaling[-1]))
            print(
                f"coordinator CPU/sample at {worker_counts[-1]} ÷ at {worker_counts[0]} "
                f"workers: {last / first:.2f}"
            )
        results["simulated"] = scaling
    if "long" in parts:
        results["long"] = long_run(flat, args.long or (1200 if quick else 100_000))
    out = args.out / ("transport_quick.json" if quick else "transport.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2))
    print(f"results: {out}")


if __name__ == "__main__":
    main()
