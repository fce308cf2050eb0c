"""What faults cost: the same build undisturbed and with a writer killed and the broker restarted.

    .venv/bin/python benchmarks/fault_recovery.py                     # 1000 samples, 640x480
    .venv/bin/python benchmarks/fault_recovery.py --num-samples 200 --broker-signal KILL

Both builds use the same config and seed. Faulted run: the writer is SIGKILLed once 30 % of the
samples are durable (the coordinator starts a new one), and the broker gets SIGTERM (or SIGKILL)
at 60 % (the coordinator restarts it with its saved state). Prints both runs, the final counts,
whether every checksum verifies, the restarts and re-issued samples, and the time lost.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

from datagen.config import load_config
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build

REPO = Path(__file__).resolve().parents[1]


def _run(config, workers, faults: dict[float, tuple[str, int]]) -> dict:
    """One build in a thread; ``faults`` maps a progress fraction to (process, signal)."""
    pids: dict[str, int] = {}
    progress = {"done": 0}
    out = Path(tempfile.mkdtemp(prefix="datagen-faults-"))

    def observe(event, details):
        if event in ("broker", "writer"):
            pids[event] = details["pid"]

    def on_progress(done, total):
        progress["done"] = done

    outcome: dict = {}

    def target():
        try:
            outcome["result"] = run_build(
                config, out, workers, on_progress=on_progress, observer=observe
            )
        except BaseException as exc:
            outcome["error"] = exc

    start = time.monotonic()
    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    injected = []
    for fraction, (what, sig) in sorted(faults.items()):
        while progress["done"] < fraction * config.num_samples and thread.is_alive():
            time.sleep(0.05)
        if thread.is_alive():
            os.kill(pids[what], sig)
            injected.append(f"{what} {signal.Signals(sig).name} at {progress['done']} durable")
            print(f"  injected: {injected[-1]}", file=sys.stderr)
    thread.join()
    seconds = time.monotonic() - start
    if "error" in outcome:
        raise outcome["error"]
    result = outcome["result"]
    manifest = verify(out)
    dataset = load(out)
    keys = dataset.keys
    row = {
        "seconds": round(seconds, 2),
        "samples": manifest["samples"],
        "unique_keys": len(set(keys)),
        "checksums_verified": True,
        "restarts": result.restarts,
        "reissued": result.reissued,
        "duplicate_messages": manifest.get("duplicate_messages"),
        "faults": injected,
    }
    for path in out.iterdir():
        path.unlink()
    out.rmdir()
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "configs/grasp_tabletop.yaml"))
    parser.add_argument("--num-samples", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--broker-signal", choices=["TERM", "KILL"], default="TERM")
    parser.add_argument(
        "--ack-timeout", type=float, default=None, help="override transfer.ack_timeout_s"
    )
    args = parser.parse_args()

    config = load_config(args.config).replace(num_samples=args.num_samples)
    if args.ack_timeout:
        config = config.replace(
            transfer=config.transfer.__class__(
                **{**config.transfer.__dict__, "ack_timeout_s": args.ack_timeout}
            )
        )
    broker_signal = getattr(signal, f"SIG{args.broker_signal}")
    print(f"undisturbed build of {args.num_samples} samples ...", file=sys.stderr)
    clean = _run(config, args.workers, {})
    print("faulted build ...", file=sys.stderr)
    faulted = _run(
        config, args.workers, {0.3: ("writer", signal.SIGKILL), 0.6: ("broker", broker_signal)}
    )
    lost = faulted["seconds"] - clean["seconds"]
    print(f"command: {' '.join(sys.argv)}")
    print(f"machine: {os.cpu_count()} cores, {platform.platform()}")
    print(
        f"{'run':<12} {'samples':>8} {'unique':>7} {'seconds':>8}  restarts / re-issued / duplicates dropped"
    )
    for name, row in (("undisturbed", clean), ("faulted", faulted)):
        print(
            f"{name:<12} {row['samples']:>8} {row['unique_keys']:>7} {row['seconds']:>8.1f}  "
            f"{row['restarts']} / {row['reissued']} / {row['duplicate_messages']}"
        )
    print(f"faults: {'; '.join(faulted['faults'])}")
    print(
        f"time lost to recovery: {lost:.1f} s ({100 * lost / clean['seconds']:.1f} % of the undisturbed build)"
    )
    results = REPO / "benchmarks/results"
    results.mkdir(parents=True, exist_ok=True)
    doc = {
        "command": " ".join(sys.argv),
        "undisturbed": clean,
        "faulted": faulted,
        "time_lost_s": round(lost, 2),
    }
    (results / "fault_recovery.json").write_text(json.dumps(doc, indent=2))
    return 0 if faulted["samples"] == clean["samples"] == args.num_samples else 1


if __name__ == "__main__":
    sys.exit(main())
