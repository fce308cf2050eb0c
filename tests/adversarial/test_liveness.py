"""Liveness, done for real on tiny builds: a worker, the local writer and the managed broker are
stopped with SIGSTOP mid-build (alive, answering nothing), a sample hangs for good, an external
writer is stopped; and a user mesh too big to decompose. Nothing is waited on forever: the
build ends with exactly N verified samples, or fails with a clear message in bounded time.
Timeouts are shortened in each config (docs/liveness.md gives the defaults)."""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import signal
import subprocess
import sys
import tarfile
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import trimesh

from datagen.assets.mesh_library import face_count
from datagen.config import BuildConfig, config_from_dict
from datagen.dataset.loader import check_complete
from datagen.errors import BuildError, ConfigError
from datagen.pipeline.run import run_build
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.wire import SECRET_ENV

pytestmark = [pytest.mark.adversarial]

REPO = Path(__file__).resolve().parents[2]
N = 6


def tiny_config(**build: Any) -> BuildConfig:
    return config_from_dict({
        "num_samples": N, "seed": 3,
        "render": {"width": 64, "height": 64, "wrist_camera": False},
        "objects": {"count": [1, 2]}, "physics": {"settle_time": 0.2},
        "transfer": {"ack_timeout_s": 5},
        "build": build,
    })  # fmt: skip


class Build(threading.Thread):
    """``run_build`` in a thread of the test process, recording the processes it started."""

    def __init__(self, out: Path, config: BuildConfig, **options: Any):
        super().__init__(daemon=True)
        self.out, self.config, self.options = out, config, options
        self.pids: dict[str, int] = {}
        self.restarts: list[dict[str, Any]] = []
        self.stalls: list[dict[str, Any]] = []
        self.progress = 0
        self.result, self.error = None, None
        self.start()

    def _observe(self, event: str, details: dict[str, Any]) -> None:
        if event == "restart":
            self.restarts.append(details)
        elif event == "stall":
            self.stalls.append(details)
        elif "pid" in details:
            self.pids.setdefault(f"{event} {details.get('id', '')}".strip(), details["pid"])

    def run(self) -> None:
        def progress(done: int, total: int) -> None:
            self.progress = done

        try:
            self.result = run_build(
                self.config, self.out, 2, on_progress=progress, observer=self._observe,
                **self.options,
            )  # fmt: skip
        except BaseException as exc:  # reported by finish()
            self.error = exc

    def wait_progress(self, done: int, timeout_s: float = 120) -> None:
        deadline = time.monotonic() + timeout_s
        while self.progress < done:
            assert self.is_alive() and time.monotonic() < deadline, self.error
            time.sleep(0.05)

    def finish(self, timeout_s: float = 180):
        self.join(timeout_s)
        assert not self.is_alive(), "the build hangs"
        if self.error:
            raise self.error
        return self.result


@contextlib.contextmanager
def stopped(pid: int):
    """SIGSTOP: the process stays alive and answers nothing; always continued afterwards."""
    os.kill(pid, signal.SIGSTOP)
    try:
        yield
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGCONT)


def build_id(out: Path) -> str:
    return json.loads((out / "build.json").read_text())["build_id"]


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_stopped_worker_is_killed_and_its_samples_made_by_another(tmp_path):
    build = Build(tmp_path, tiny_config(worker_timeout_s=10))
    build.wait_progress(1)
    with stopped(build.pids["worker 0"]):
        result = build.finish()
    assert result.restarts["worker"] >= 1
    assert any("sent nothing for" in r["why"] for r in build.restarts if r["what"] == "worker")
    check_complete(tmp_path, N, build_id(tmp_path))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_stopped_local_writer_is_killed_and_restarted(tmp_path):
    build = Build(tmp_path, tiny_config(writer_timeout_s=5))
    build.wait_progress(1)
    with stopped(build.pids["writer 0"]):
        result = build.finish()
    assert result.restarts["writer"] == 1
    assert "sent nothing for" in next(r["why"] for r in build.restarts if r["what"] == "writer")
    check_complete(tmp_path, N, build_id(tmp_path))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_stopped_managed_broker_is_killed_and_restarted(tmp_path):
    build = Build(tmp_path, tiny_config(broker_timeout_s=5, writer_timeout_s=5))
    build.wait_progress(1)
    with stopped(build.pids["broker"]):
        result = build.finish()
    assert result.restarts["broker"] == 1
    assert result.restarts["writer"] == 0  # a hung broker silences the writer: not its fault
    check_complete(tmp_path, N, build_id(tmp_path))


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_stopped_external_writer_stops_the_build_with_what_to_do(
    tmp_path, broker, start_writer, build_id, monkeypatch
):
    monkeypatch.setenv(SECRET_ENV, secrets.token_hex(32))
    writer = start_writer(out=tmp_path / "ds", writer_id="w1")
    config = tiny_config(writer_timeout_s=5, outage_wait_s=5)
    build = Build(tmp_path / "ds", config, broker_url=broker.url, writers=["w1"], build_id=build_id)
    build.wait_progress(1)
    with stopped(writer.proc.pid):
        stopped_at = time.monotonic()
        with pytest.raises(BuildError) as failure:
            build.finish(timeout_s=60)
        waited = time.monotonic() - stopped_at
    message = str(failure.value)
    assert "writer 'w1' has sent nothing for" in message and "kill -CONT" in message
    assert "build.outage_wait_s" in message and "--resume" in message
    assert waited < 5 + 5 + 15  # the timeouts and some slack, never a hang
    assert build.stalls and "w1" in build.stalls[0]["problem"]  # reported before giving up


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_stopped_external_broker_stops_the_build_with_what_to_do(tmp_path):
    with ManagedBroker() as external:  # started by someone else, as far as the build knows
        build = Build(tmp_path, tiny_config(broker_timeout_s=5, outage_wait_s=5), broker_url=external.url)  # fmt: skip
        build.wait_progress(1)
        with stopped(external.pid):
            stopped_at = time.monotonic()
            with pytest.raises(BuildError) as failure:
                build.finish(timeout_s=90)
            waited = time.monotonic() - stopped_at
    message = str(failure.value)
    assert f"the broker at 127.0.0.1:{external.port} has not answered for" in message
    assert "kill -CONT" in message and "--resume" in message and "not durable" in message
    assert waited < 5 + 5 + 25  # the timeouts, the clean-up, some slack: never a hang
    assert build.stalls


def _blocks(tmp_path: Path, hang: str, build: str) -> subprocess.CompletedProcess:
    config = tmp_path / "blocks.yaml"
    config.write_text(
        f"scene: example_blocks\nnum_samples: {N}\nseed: 7\n"
        f"render: {{width: 64, height: 64}}\nbuild: {build}\n"
    )
    path = os.pathsep.join(filter(None, [str(REPO / "tests" / "plugins"), os.environ.get("PYTHONPATH")]))  # fmt: skip
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", "build", str(config), "--out", str(tmp_path / "out"), "--workers", "2", "--no-preview"],
        capture_output=True, text=True, cwd=REPO, timeout=300,
        env=os.environ | {"PYTHONPATH": path, "EXAMPLE_BLOCKS_HANG": hang},
    )  # fmt: skip


def _shard_samples(out: Path) -> dict[str, dict[str, Any]]:
    """Key -> metadata of every sample in the shards (a failed build writes no manifest)."""
    found = {}
    for shard in out.glob("shard-*.tar"):
        with tarfile.open(shard) as tar:
            for member in tar.getmembers():
                if member.name.endswith(".json"):
                    found[member.name.split(".")[0]] = json.load(tar.extractfile(member))
    return found


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_hanging_sample_times_out_is_issued_again_and_at_last_reported(tmp_path):
    # sample 2 hangs at attempt 0 only, sample 4 at every attempt; heartbeats go on meanwhile
    run = _blocks(tmp_path, hang="2:1,4:99", build="{retries: 1, sample_timeout_s: 6}")
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr
    assert "1 of 6 samples failed on every attempt" in run.stderr
    assert "sample 4:" in run.stderr and "attempt 1: timed out after 6 s" in run.stderr
    samples = _shard_samples(tmp_path / "out")
    assert sorted(samples) == [f"{i:09d}" for i in range(N) if i != 4]
    production = samples["000000002"]["production"]
    assert production["attempt"] == 1
    assert production["failures"][0].startswith("attempt 0: timed out after 6 s")


def test_a_mesh_with_too_many_faces_is_refused_before_anything_starts(tmp_path):
    assets = tmp_path / "assets" / "ball"
    assets.mkdir(parents=True)
    trimesh.creation.icosphere(subdivisions=3).export(assets / "ball.obj")  # 1280 faces
    config = {"scene": "grasp_tabletop", "objects": {"source": "folder", "assets_dir": str(tmp_path / "assets")}}  # fmt: skip
    config_from_dict(config)  # within the default limit
    config["objects"]["max_mesh_faces"] = 1000
    with pytest.raises(ConfigError, match=r"ball\.obj has 1280 faces, more than objects\.max_mesh_faces \(1000\)"):  # fmt: skip
        config_from_dict(config)
    # ten million faces (a sparse binary STL: 500 MB on paper, nothing on disk): read cheaply
    huge = assets / "huge.stl"
    with huge.open("wb") as f:
        f.write(bytes(80) + (10_000_000).to_bytes(4, "little"))
        f.truncate(84 + 50 * 10_000_000)
    del config["objects"]["max_mesh_faces"]
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"huge\.stl has 10000000 faces, more than objects\.max_mesh_faces \(1000000\)"):  # fmt: skip
        config_from_dict(config)
    assert time.perf_counter() - start < 2.0


@pytest.mark.parametrize("suffix", ["obj", "stl", "ply", "glb"])
def test_face_counts_are_read_from_headers_and_records(tmp_path, suffix):
    mesh = trimesh.creation.icosphere(subdivisions=2)
    path = tmp_path / f"mesh.{suffix}"
    mesh.export(path)
    assert face_count(path) == len(mesh.faces) == 320
