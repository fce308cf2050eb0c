"""Hundreds of simulated workers (datagen/pipeline/executors/simulated.py) against a real
Mosquitto and a real writer: they crash, hang and publish twice, and the build still ends with
exactly N unique, verified samples, each the recorded sample it replays, re-keyed."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import pytest

from datagen.config import BuildConfig
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build

pytestmark = [pytest.mark.mqtt, pytest.mark.slow]  # a real broker, writer and host processes

WORKERS, SAMPLES = 200, 2000
FAULTS = {"render_s": (0.0, 0.05), "crash": 0.01, "hang": 0.005, "duplicate": 0.03}


@pytest.fixture(scope="module")
def simulated_build(frames_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("simulated") / "out"
    base = BuildConfig()
    config = base.replace(
        num_samples=SAMPLES,
        seed=11,
        output=replace(base.output, formats=("webdataset",)),
        build=replace(base.build, worker_timeout_s=4.0),
    )
    options = {"recorded": str(frames_dataset), "faults": FAULTS, "hosts": 2}
    result = run_build(config, out, WORKERS, executor="simulated", executor_options=options)
    return out, result


def test_faults_of_hundreds_of_workers_still_give_exactly_n_verified_samples(simulated_build):
    out, result = simulated_build
    assert result.samples == SAMPLES
    assert result.restarts["worker"] > 0  # crashed and hung workers were replaced
    verify(out)  # every shard member against the manifest's digests
    dataset = load(out)
    assert len(dataset) == SAMPLES == len(set(dataset.keys))
    for i in range(0, SAMPLES, 97):
        meta = dataset.metadata(i)
        assert (meta["index"], meta["key"], meta["seed"]) == (i, dataset.keys[i], 11)


def test_each_sample_is_its_recorded_sample_re_keyed(simulated_build, frames_dataset):
    out, _ = simulated_build
    dataset, recorded = load(out), load(frames_dataset)
    for i in (0, 1, 5, 1999):
        replayed, source = dataset.raw(i), recorded.raw(i % len(recorded))
        assert replayed.keys() == source.keys()
        assert all(replayed[name] == source[name] for name in source if name != "json")


def test_the_simulated_executor_without_a_dataset_is_one_line(tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text("num_samples: 4\n")
    command = ["build", str(config), "--out", str(tmp_path / "o"), "--executor", "simulated"]
    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", *command], capture_output=True, text=True, timeout=300
    )
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr, done.stderr[-2000:]
    assert any("--replay DATASET" in line for line in lines), done.stderr[-2000:]
