"""Workers on a local Ray instance, recycled workers and samples spread over two brokers: the
same dataset as local processes, exactly N samples, and a Ray worker killed for real is
replaced."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import signal
import tarfile

import psutil
import pytest
from conftest import descendants_running  # tests/conftest.py: a test's own processes

from datagen.config import BuildConfig
from datagen.config.sections import ExecutorConfig, ObjectsConfig, PhysicsConfig, RenderConfig
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build
from datagen.sample import sample_key
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.wire import SECRET_ENV

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]  # real builds

SAMPLES = 10
CONFIG = BuildConfig(  # executors, not scenes: few objects, short settling, one camera
    num_samples=SAMPLES,
    seed=4,
    render=RenderConfig(width=128, height=96, wrist_camera=False),
    objects=ObjectsConfig(count=(1, 2)),
    physics=PhysicsConfig(settle_time=0.3),
)


def _parts(root):
    dataset = load(root)
    return dataset.keys, [dataset.raw(i) for i in range(len(dataset))]


@pytest.fixture(scope="module")
def recycled_local(tmp_path_factory):
    events = []
    out = tmp_path_factory.mktemp("local") / "recycled"
    config = dataclasses.replace(CONFIG, executor=ExecutorConfig(recycle_after=3))
    result = run_build(config, out, workers=2, observer=lambda kind, d: events.append((kind, d)))
    return out, result, events


def test_recycled_workers_make_exactly_n_samples(recycled_local):
    out, result, events = recycled_local
    assert verify(out)["samples"] == SAMPLES
    recycled = [d for kind, d in events if kind == "recycle"]
    started = [d for kind, d in events if kind == "worker"]
    assert len(recycled) >= 2 and all(d["samples"] == 3 for d in recycled)
    assert len(started) >= 2 + len(recycled) - 1  # replacements (not for the last ones)
    assert result.restarts["worker"] == 0  # recycling is not a fault


@pytest.mark.ray
def test_ray_executor_builds_the_same_dataset(recycled_local, tmp_path):
    out = tmp_path / "ray"
    events = []
    result = run_build(
        CONFIG, out, workers=2, executor="ray", observer=lambda k, d: events.append((k, d))
    )
    assert result.samples == SAMPLES and verify(out)["samples"] == SAMPLES
    assert any("ray_actor" in d for kind, d in events if kind == "worker")
    assert _parts(out) == _parts(recycled_local[0])


def test_two_sample_brokers_build_the_same_dataset_byte_for_byte(
    recycled_local, tmp_path, broker, build_id, start_writer, monkeypatch
):
    """Sample i goes to broker i mod 2, each with a writer of its own; the build's broker
    carries the control plane and broker 0's samples; one manifest, one verify."""
    monkeypatch.setenv(SECRET_ENV, os.urandom(32).hex())
    out = tmp_path / "two"
    with ManagedBroker() as second:
        writers = [
            start_writer(out=out, writer_id="w0", shard_size=4),
            start_writer(
                out=out, writer_id="w1", shard_size=4, args=["--sample-broker", second.url]
            ),
        ]
        result = run_build(
            CONFIG,
            out,
            workers=2,
            broker_url=broker.url,
            sample_broker_urls=[broker.url, second.url],
            writers=["w0", "w1"],
            build_id=build_id,
        )
        for writer in writers:
            assert writer.wait(30) == 0, writer.log()
    assert result.samples == SAMPLES and verify(out)["samples"] == SAMPLES
    assert _parts(out) == _parts(recycled_local[0])
    for k, writer_id in enumerate(("w0", "w1")):
        held = set()
        for shard in out.glob(f"shard-{writer_id}-*.tar"):
            with tarfile.open(shard) as tar:
                held |= {name.split(".")[0] for name in tar.getnames()}
        assert held == {sample_key(i) for i in range(k, SAMPLES, 2)}, (writer_id, sorted(held))


@pytest.mark.ray
def test_a_killed_ray_worker_is_replaced(tmp_path):
    killed = []

    def on_progress(done: int, total: int) -> None:
        if done >= 3 and not killed:
            workers = descendants_running("SceneWorker")
            if workers:
                workers[0].send_signal(signal.SIGKILL)
                killed.append(workers[0].pid)

    out = tmp_path / "ray-kill"
    config = dataclasses.replace(CONFIG, num_samples=16)
    result = run_build(config, out, workers=2, executor="ray", on_progress=on_progress)
    assert killed, "no Ray worker process was found to kill"
    assert verify(out)["samples"] == 16 and len(set(load(out).keys)) == 16
    assert result.restarts["worker"] >= 1


@pytest.mark.ray
@pytest.mark.adversarial
def test_a_stopped_ray_worker_is_killed_and_replaced(tmp_path):
    """SIGSTOP: the actor is alive but answers no ping; ``ray.kill`` ends it (docs/liveness.md)."""
    stopped: list[psutil.Process] = []

    def on_progress(done: int, total: int) -> None:
        if done >= 2 and not stopped:
            workers = descendants_running("SceneWorker")
            if workers:
                workers[0].send_signal(signal.SIGSTOP)
                stopped.append(workers[0])

    config = dataclasses.replace(
        CONFIG, build=dataclasses.replace(CONFIG.build, worker_timeout_s=10.0)
    )
    try:
        result = run_build(
            config, tmp_path / "ray-stop", workers=2, executor="ray", on_progress=on_progress
        )
    finally:
        for process in stopped:
            with contextlib.suppress(psutil.NoSuchProcess):
                process.send_signal(signal.SIGCONT)
    assert stopped, "no Ray worker process was found to stop"
    assert not stopped[0].is_running()  # killed, although stopped
    assert verify(out := tmp_path / "ray-stop")["samples"] == SAMPLES
    assert len(set(load(out).keys)) == SAMPLES and result.restarts["worker"] >= 1
