"""benchmarks/transport.py --quick end to end, run as docs/scale-out.md prints it: a recorded
set, the engine against the raw broker, and simulated workers with faults ending with their
exact, verified count, leaving nothing behind in the temp folder."""

from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest
from printed_commands import printed_line  # tests/printed_commands.py

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "scale-out.md"

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]


def test_the_quick_transport_benchmark_prints_its_ratio_and_an_exact_verified_count(tmp_path):
    command = printed_line(DOC, "transport.py --quick")
    temp = tmp_path / "tmp"
    temp.mkdir()
    done = subprocess.run(
        ["bash", "-c", command],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=1200,
        env=os.environ | {"TMPDIR": str(temp)},
    )
    assert done.returncode == 0, done.stderr[-3000:]
    # each engine run's dataset (1.5 GB at 2000 default samples) is gone once verified
    assert not [p.name for p in temp.iterdir() if p.name.startswith("datagen-")]
    out = done.stdout
    assert re.search(r"engine ÷ raw: \d+\.\d\d ± \d+\.\d\d", out), out
    assert re.search(r"the writer's steps: [\d.]+ ms, at most \d+ samples/s a core", out), out
    assert re.search(r"simulated workers 100: .* 600 of 600 samples, verified: True", out), out
    assert re.search(r"two brokers ÷ one: \d+\.\d\d", out), out
    assert re.search(r"2 broker\(s\), 2 writers: .* 600 of 600 samples, verified: True", out), out
    assert re.search(r"long run: 1200 samples, verified: True; latency p50/p90/p99 [\d.]+/", out)
    assert re.search(r"coordinator RSS MB at 10%/100%: [\d.]+ / [\d.]+", out), out
    results = json.loads((REPO / "benchmarks/results/transport_quick.json").read_text())
    two = results["sets"]["flat"]["brokers"]["runs"][1]
    assert two["brokers"] == 2 and two["verified"] and two["latency"]["samples"] > 0
    steps = results["sets"]["flat"]["steps_ms"]
    assert len(steps) == 5 and all(ms > 0 for ms in steps.values()), steps
    run = results["sets"]["flat"]["runs"][0]
    assert run["engine"]["verified"] and run["raw"]["received"] == 600
    assert set(run["engine"]["cpu_ms_per_sample"]) == {
        "broker",
        "coordinator",
        "producer",
        "writer",
    }
