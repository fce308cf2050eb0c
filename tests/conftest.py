"""Shared fixtures. Transfer/writer/loader fixtures: ``broker``, ``build_id``,
``make_sample``, ``start_writer`` (real Mosquitto, real writer processes, no mocks)."""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import shutil
import signal
import subprocess
import sys
import uuid
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from types import ModuleType

import cv2
import numpy as np
import psutil
import pytest
import yaml

from datagen.sample import Sample
from datagen.shards import keys_sha256, write_json_durably
from datagen.transport.mosquitto import ManagedBroker
from datagen.writer.journal import journal_path
from datagen.writer.shard_writer import ShardWriter

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def broker() -> Iterator[ManagedBroker]:
    """One Mosquitto for the session; tests isolate themselves with a fresh ``build_id``."""
    with ManagedBroker() as b:
        yield b


@pytest.fixture
def build_id() -> str:
    return "test-" + uuid.uuid4().hex[:10]


def synthetic_arrays(index: int, height: int = 24, width: int = 32) -> dict:
    """Random images seeded by ``index``: rgb HxWx3 uint8 (RGB order), depth uint16 mm,
    seg uint16 instance ids, semantic uint8 class ids, and a metadata dict."""
    rng = np.random.default_rng(index)
    return {
        "rgb": rng.integers(0, 256, (height, width, 3), dtype=np.uint8),
        "depth": rng.integers(0, 5000, (height, width), dtype=np.uint16),
        "seg": rng.integers(0, 20, (height, width), dtype=np.uint16),
        "semantic": rng.integers(0, 8, (height, width), dtype=np.uint8),
        "meta": {
            "index": index,
            "camera": {"fov_deg": 60.0},
            "objects": [{"id": 1, "class": "box"}],
        },
    }


def _png(a: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", a)
    assert ok
    return buf.tobytes()


def synthetic_sample(index: int, height: int = 24, width: int = 32) -> Sample:
    """A sample with real PNG parts (``synthetic_arrays``) and a JSON part."""
    a = synthetic_arrays(index, height, width)
    return Sample(
        index,
        {
            "rgb.png": _png(a["rgb"][:, :, ::-1]),  # cv2 writes BGR
            "depth.png": _png(a["depth"]),
            "seg.png": _png(a["seg"]),
            "semantic.png": _png(a["semantic"]),
            "json": json.dumps(a["meta"]).encode(),
        },
    )


@pytest.fixture
def make_sample() -> Callable[..., Sample]:
    return synthetic_sample


@pytest.fixture
def make_arrays() -> Callable[..., dict]:
    return synthetic_arrays


def write_dataset(
    out: Path, samples: list[Sample], shard_size: int = 4, writer_id: str = "0"
) -> Path:
    """A finalized dataset written directly (no MQTT): shards plus manifest.json."""
    with ShardWriter(out, writer_id, shard_size) as sink:
        for s in samples:
            sink.write(s)
    doc = {
        "samples": len(samples),
        "shards": [s.to_json() for s in sink.shards],
        "keys_sha256": keys_sha256(s.key for s in samples),
    }
    write_json_durably(out, doc)
    journal_path(out, writer_id).unlink()
    return out


@pytest.fixture
def make_dataset() -> Callable[..., Path]:
    return write_dataset


class WriterProcess:
    """``datagen writer`` as a subprocess, its log in ``log_path``."""

    def __init__(
        self,
        url: str,
        build_id: str,
        out: Path,
        writer_id: str,
        shard_size: int,
        log_path: Path,
        args: Sequence[str] = (),
    ):
        self.out, self.writer_id, self.log_path = out, writer_id, log_path
        cmd = [sys.executable, "-m", "datagen.cli", "writer", "--build-id", build_id]
        cmd += ["--out", str(out), "--writer-id", writer_id, "--shard-size", str(shard_size)]
        with open(log_path, "ab") as log:
            self.proc = subprocess.Popen(
                [*cmd, *args],
                cwd=REPO,
                env=os.environ | {"DATAGEN_BROKER_URL": url},  # keeps the password off argv
                stdout=log,
                stderr=log,
                stdin=subprocess.DEVNULL,
            )

    def wait(self, timeout_s: float = 30.0) -> int:
        try:
            return self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"writer still running; log:\n{self.log()}") from None

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def stop(self) -> None:
        """SIGKILL, as in a crash."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture
def start_writer(
    broker: ManagedBroker, build_id: str, tmp_path: Path
) -> Iterator[Callable[..., WriterProcess]]:
    """Factory: ``start_writer(out=tmp_path/'ds', writer_id='0', shard_size=16, broker_url=None,
    args=())`` (default: the session ``broker``; ``args``: more writer options); writers still
    running at teardown are killed."""
    started: list[WriterProcess] = []

    def start(
        out: Path | None = None,
        writer_id: str = "0",
        shard_size: int = 16,
        broker_url: str | None = None,
        args: Sequence[str] = (),
    ) -> WriterProcess:
        w = WriterProcess(
            broker_url or broker.url,
            build_id,
            out or tmp_path / "ds",
            writer_id,
            shard_size,
            tmp_path / f"writer-{writer_id}.log",
            args,
        )
        started.append(w)
        return w

    yield start
    for w in started:
        w.stop()


@pytest.fixture
def benchmark_module(monkeypatch) -> Callable[[str], ModuleType]:
    """A script of ``benchmarks/`` imported as a module, as it imports its neighbours (that
    folder on the path)."""

    def imported(name: str) -> ModuleType:
        monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
        return importlib.import_module(name)

    return imported


def python_lines(code: str, *args: object, timeout: float = 600) -> list[str]:
    """The stdout lines of ``code`` run by this interpreter in a fresh process at the
    repository root (``python -c code ARGS``); its stderr's tail when it fails."""
    done = subprocess.run(
        [sys.executable, "-c", code, *map(str, args)],
        cwd=Path(__file__).resolve().parents[1],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.splitlines()


def _sigint_ignored() -> bool:
    """At the C level: children inherit an ignored or blocked SIGINT and never see Ctrl-C."""
    for line in Path("/proc/thread-self/status").read_text().splitlines():
        if line.startswith(("SigIgn:", "SigBlk:")) and int(line.split()[1], 16) & (1 << (2 - 1)):
            return True
    return False


def _restore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def pytest_sessionstart(session):
    # a shell without job control hands a background command (`... &`) SIGINT ignored: start
    # from the default, so that the check below sees only what a test did
    if _sigint_ignored():
        _restore_sigint()


@pytest.fixture(autouse=True)
def _sigint_stays_default(request):
    yield
    if _sigint_ignored():
        _restore_sigint()
        pytest.fail(f"{request.node.nodeid} left SIGINT ignored or blocked in the test process")


# --- datasets built once per session by the real command line (workers, broker, writer): tests
# and doc snippets copy them before writing into them ---------------------------------------------
CAMPAIGN = {  # 3 attempts filmed at the rows' rate, workspace and wrist cameras
    "version": 1, "scene": "grasp_attempts", "num_samples": 3, "seed": 5,
    "render": {"width": 128, "height": 96, "wrist_camera": True},
    "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 10, "frame_hz": 10},
}  # fmt: skip
NAVIGATION = {
    "version": 1, "scene": "navigation", "num_samples": 2, "seed": 3,
    "render": {"width": 96, "height": 72, "far": 20.0},
    "navigation": {"family": "corridor", "frame_rate_hz": 2},
}  # fmt: skip
AERIAL = {  # two drones in a corridor, a downward camera each
    "version": 1, "scene": "aerial", "num_samples": 2, "seed": 4,
    "render": {"width": 96, "height": 72, "far": 20.0},
    "aerial": {"family": "corridor", "drones": 2, "frame_rate_hz": 2, "down_camera": True},
}  # fmt: skip
FRAMES = {  # grasp frames from two cameras
    "version": 1, "scene": "grasp_tabletop", "num_samples": 4, "seed": 2,
    "render": {"width": 160, "height": 120, "views": 2},
}  # fmt: skip


def descendants_running(text: str, pid: int | None = None) -> list[psutil.Process]:
    """The descendants of process ``pid`` (this one by default) whose command line holds
    ``text``: a test's own builds, brokers and workers, not those of a test running beside it
    (the suite's second run has two workers)."""
    found = []
    for process in psutil.Process(pid).children(recursive=True):
        with contextlib.suppress(psutil.NoSuchProcess):
            if text in " ".join(process.cmdline()):
                found.append(process)
    return found


def build_dataset(tmp: Path, name: str, config: dict, command: list[str]) -> Path:
    """``tmp/name``, made from ``config`` by the datagen command ``command`` with one worker."""
    path, out = tmp / f"{name}.yaml", tmp / name
    path.write_text(yaml.safe_dump(config))
    done = subprocess.run(
        [sys.executable, "-m", "datagen.cli", *command, str(path), "--out", str(out), "--workers", "1"],
        capture_output=True, text=True, cwd=REPO, timeout=900, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return out


@pytest.fixture(scope="session")
def campaign_dataset(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("campaign")
    return build_dataset(tmp, "campaign", CAMPAIGN, ["campaign", "grasp"])


@pytest.fixture(scope="session")
def navigation_dataset(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("navigation")
    return build_dataset(tmp, "navigation", NAVIGATION, ["build"])


@pytest.fixture(scope="session")
def aerial_dataset(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("aerial")
    return build_dataset(tmp, "aerial", AERIAL, ["build"])


@pytest.fixture(scope="session")
def frames_dataset(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("frames")
    return build_dataset(tmp, "frames", FRAMES, ["build"])


@pytest.fixture(scope="session")
def readers_python() -> Path:
    """The interpreter of the separate environment (``.venv-readers``, made by
    scripts/readers_env.sh, which the test command runs) with lerobot 0.4.4, mlcroissant and robomimic, the
    readers the export tests load datagen's exports with."""
    python = REPO / ".venv-readers" / "bin" / "python"
    if not python.exists():
        pytest.fail(
            f"{python} is missing: run 'bash scripts/readers_env.sh' (the test command does)"
        )
    return python


def export_copy(source: Path, root: Path, formats: str) -> subprocess.CompletedProcess:
    """``source`` (a session dataset) copied to ``root``, then ``datagen export ROOT --to
    FORMATS`` run there by the real command line; its result (the caller checks it)."""
    shutil.copytree(source, root)
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", "export", str(root), "--to", formats],
        capture_output=True, text=True, cwd=REPO, timeout=300, check=False,
    )  # fmt: skip
