"""Faults done for real during real builds: processes killed, the broker restarted, duplicates
and hostile messages published, the coordinator interrupted and the build resumed.

Every test ends with the same check: exactly N samples, unique keys, every checksum verified.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import paho.mqtt.client as mqtt
import psutil
import pytest
import yaml

from datagen.config import BuildConfig, config_from_dict
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build
from datagen.sample import Sample
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.publisher import SamplePublisher
from datagen.transport.run_binding import RunBinding, config_digest
from datagen.transport.topics import topics
from datagen.transport.wire import encode_sample
from datagen.writer.journal_lines import journal_entries

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]  # real builds

REPO = Path(__file__).resolve().parents[2]
N = 30
CONFIG = config_from_dict({  # faults of the pipeline: few objects, short settling, one camera
    "num_samples": N, "seed": 11,
    "render": {"width": 160, "height": 120, "wrist_camera": False},
    "objects": {"count": [1, 2]}, "physics": {"settle_time": 0.3},
    "transfer": {"ack_timeout_s": 5.0},
})  # fmt: skip


def assert_complete(out: Path, n: int = N) -> dict:
    manifest = verify(out)
    dataset = load(out)
    keys = [dataset[i]["key"] for i in range(len(dataset))]
    assert manifest["samples"] == len(dataset) == n
    assert keys == [f"{i:09d}" for i in range(n)]  # unique, and exactly the requested ones
    return manifest


class BuildThread:
    """``run_build`` in a thread of the test process, recording what it started."""

    def __init__(self, out: Path, config: BuildConfig = CONFIG, workers: int = 2):
        self.out, self.events, self.progress = out, {}, 0
        self.result, self.error = None, None
        self.thread = threading.Thread(target=self._run, args=(config, workers), daemon=True)
        self.thread.start()

    def _observe(self, event, details):
        if event == "worker":
            self.events.setdefault("workers", {})[details["id"]] = details["pid"]
        elif event == "restart":
            self.events.setdefault("restarts", []).append(details)
        else:
            self.events[event] = details

    def _run(self, config, workers):
        def progress(done, total):
            self.progress = done

        try:
            self.result = run_build(
                config, self.out, workers, on_progress=progress, observer=self._observe
            )
        except BaseException as exc:  # reported by join()
            self.error = exc

    def wait_progress(self, done: int, timeout_s: float = 180) -> None:
        deadline = time.monotonic() + timeout_s
        while self.progress < done:
            assert self.thread.is_alive() and time.monotonic() < deadline, self.error
            time.sleep(0.05)

    def join(self, timeout_s: float = 300):
        self.thread.join(timeout_s)
        assert not self.thread.is_alive(), "the build did not finish"
        if self.error:
            raise self.error
        return self.result


def test_a_killed_worker_is_replaced_and_its_samples_made_again(tmp_path):
    build = BuildThread(tmp_path)
    build.wait_progress(6)
    os.kill(build.events["workers"][0], signal.SIGKILL)
    result = build.join()
    assert result.restarts["worker"] >= 1
    assert_complete(tmp_path)


def test_a_killed_writer_is_restarted_and_nothing_is_lost(tmp_path):
    build = BuildThread(tmp_path)
    build.wait_progress(8)
    os.kill(build.events["writer"]["pid"], signal.SIGKILL)
    result = build.join()
    assert result.restarts["writer"] == 1
    assert_complete(tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_broker_restart_mid_build(tmp_path, sig):
    build = BuildThread(tmp_path)
    build.wait_progress(8)
    os.kill(build.events["broker"]["pid"], sig)
    result = build.join()
    assert result.restarts["broker"] == 1
    assert_complete(tmp_path)


def _produce(index: int) -> Sample:
    from datagen.families.grasp_tabletop.produce import produce

    return produce(CONFIG, CONFIG.seed, index)


def test_injected_duplicates_are_written_once(tmp_path):
    duplicates = [_produce(i) for i in (0, 1, 2)]  # identical to what the workers make
    build = BuildThread(tmp_path)
    build.wait_progress(5)
    url, build_id = build.events["broker"]["url"], _build_id(tmp_path)
    secret = _secret(tmp_path)  # as a worker of the build would, in the build's run
    run = RunBinding(_run_id(url, build_id), config_digest(CONFIG.to_dict()), CONFIG.seed)
    with SamplePublisher(url, build_id, "test-duplicates", secret=secret, run=run) as publisher:
        for _ in range(3):
            for sample in duplicates:
                publisher.publish(sample)
    build.join()
    manifest = assert_complete(tmp_path)
    assert manifest["duplicate_messages"] >= 9 - 3  # some may arrive before the worker's copy
    dataset = load(tmp_path)
    for sample in duplicates:
        assert dataset.raw(sample.index)["json"] == sample.parts["json"]


def _build_id(out: Path) -> str:
    return json.loads((out / "build.json").read_text())["build_id"]


def _secret(out: Path) -> bytes:
    return bytes.fromhex(json.loads((out / "build.json").read_text())["secret"])


def _run_id(url: str, build_id: str) -> str:
    """The run of the build, as a worker knows it: read here from the writer's retained status
    (the envelope names its run)."""
    address = parse_broker_url(url)
    got = threading.Event()
    found: list[str] = []

    def on_message(client, userdata, message) -> None:
        run = json.loads(message.payload).get("run")
        if run:
            found.append(run)
            got.set()

    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5)
    client.username_pw_set(address.username, address.password)
    client.on_message = on_message
    client.connect(address.host, address.port)
    client.subscribe(topics(build_id).status("0"))
    client.loop_start()
    try:
        assert got.wait(30), "no status of the writer names the run"
    finally:
        client.loop_stop()
        client.disconnect()
    return found[0]


def _hostile_payloads(build_id: str, secret: bytes) -> list[bytes]:
    run = RunBinding.draw({}, 0)  # not the build's: a run of this build id, its secret
    genuine = encode_sample(build_id, Sample(3, {"json": b'{"x":1}'}), secret, run)
    wrong_version = bytearray(genuine)
    wrong_version[4] = 9
    return [
        b"",
        b"not a sample at all",
        os.urandom(4096),
        genuine[: len(genuine) // 2],  # truncated
        bytes(wrong_version),
        encode_sample("some-other-build", Sample(4, {"json": b"{}"})),
        genuine[:-1] + bytes([genuine[-1] ^ 0xFF]),  # bad CRC
        json.dumps({"index": 5, "rgb": "pickle?"}).encode(),
        # forged: well-formed samples of this build that no worker made
        encode_sample(build_id, Sample(6, {"json": b'{"x":1}'})),  # unsigned
        encode_sample(build_id, Sample(7, {"json": b'{"x":1}'}), os.urandom(32), run),  # wrong key
        encode_sample(build_id, Sample(10**6, {"json": b'{"x":1}'}), os.urandom(32), run),
        genuine,  # signed with the build's secret, in another run
    ]


def test_hostile_messages_are_rejected_counted_and_never_enter_the_dataset(tmp_path):
    build = BuildThread(tmp_path)
    build.wait_progress(3)
    address = parse_broker_url(build.events["broker"]["url"])
    build_id = _build_id(tmp_path)
    client = mqtt.Client(
        mqtt.CallbackAPIVersion.VERSION2, client_id="test-hostile", protocol=mqtt.MQTTv5
    )
    client.username_pw_set(address.username, address.password)
    client.connect(address.host, address.port)
    client.loop_start()
    payloads = _hostile_payloads(build_id, _secret(tmp_path))
    for payload in payloads:
        client.publish(topics(build_id).samples, payload, qos=1).wait_for_publish(10)
    client.loop_stop()
    client.disconnect()
    build.join()
    manifest = assert_complete(tmp_path)
    assert manifest["rejected_messages"] >= len(payloads)
    dataset = load(tmp_path)
    assert all(dataset.raw(i)["json"] != b'{"x":1}' for i in range(len(dataset)))


# --- resume: the coordinator is a separate process here, interrupted for real -------------------


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted build to compare resumed builds with."""
    out = tmp_path_factory.mktemp("reference")
    run_build(CONFIG, out, workers=2)
    return out


def _config_file(tmp_path: Path) -> Path:
    path = tmp_path / "faults.yaml"
    path.write_text(yaml.safe_dump(CONFIG.to_dict()))
    return path


def _start_cli_build(tmp_path: Path, out: Path, *options: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "datagen.cli", "build", str(_config_file(tmp_path)), "--out", str(out), "--workers", "2", *options, "--no-preview"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip


def _wait_for_samples_on_disk(
    out: Path, minimum_bytes: int = 60_000, timeout_s: float = 120
) -> None:
    """Until the shards hold ``minimum_bytes`` and the writer has journalled a sample as
    durable: bytes in a shard are not yet durable (on a loaded machine the kill can come
    between the two, and the resumed build then has nothing to keep)."""
    deadline = time.monotonic() + timeout_s
    while _shard_bytes(out) < minimum_bytes or not _journalled_durable(out):
        assert time.monotonic() < deadline, "the build wrote nothing durable"
        time.sleep(0.2)


def _shard_bytes(out: Path) -> int:
    return sum(p.stat().st_size for p in out.glob("*.tar"))


def _journalled_durable(out: Path) -> bool:
    """Whether a writer's journal has a line making a sample durable (read as recovery reads
    it: a line the writer is still appending is skipped)."""
    return any(
        entry["samples"] > 0
        for journal in out.glob(".writer-*.journal")
        for entry in journal_entries(journal, strict=False)
    )


def _processes_using(out: Path) -> list[psutil.Process]:
    found = []
    for process in psutil.process_iter(["cmdline"]):
        if str(out) in " ".join(process.info["cmdline"] or []):
            found.append(process)
    return found


def _resume_and_compare(tmp_path: Path, out: Path, reference: Path, printed: str = "") -> None:
    """Resumes the build (with the command it ``printed``, run exactly as printed, if given),
    then compares every sample with the uninterrupted build's."""
    command = ["bash", "-c", printed] if printed else [sys.executable, "-m", "datagen.cli", "build", str(_config_file(tmp_path)), "--out", str(out), "--workers", "2", "--no-preview", "--resume"]  # fmt: skip
    resumed = subprocess.run(
        command, cwd=REPO, capture_output=True, text=True, timeout=300,
        env=os.environ | {"PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"},
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    assert "were already durable" in resumed.stdout
    assert_complete(out)
    ours, theirs = load(out), load(reference)
    for i in range(N):
        a, b = ours[i], theirs[i]
        assert json.dumps(a["meta"], sort_keys=True) == json.dumps(b["meta"], sort_keys=True)
        for part in ("rgb", "depth", "seg", "semantic"):
            assert np.array_equal(a[part], b[part]), (i, part)


def test_resume_after_the_coordinator_is_killed(tmp_path, reference):
    out = tmp_path / "out"
    process = _start_cli_build(tmp_path, out)
    _wait_for_samples_on_disk(out)
    process.kill()  # SIGKILL: no clean-up at all
    process.wait(timeout=30)
    deadline = time.monotonic() + 20
    while _processes_using(out) and time.monotonic() < deadline:
        time.sleep(0.2)  # the writer follows its parent (PR_SET_PDEATHSIG)
    assert _processes_using(out) == []
    assert not (out / "manifest.json").exists()
    _resume_and_compare(tmp_path, out, reference)


def test_resume_after_ctrl_c(tmp_path, reference):
    """Ctrl-C prints the command that finishes the build (every option given, then ``--resume``);
    run exactly as printed, it makes the uninterrupted build's dataset."""
    out = tmp_path / "out"
    process = _start_cli_build(tmp_path, out, "--seed", str(CONFIG.seed))
    _wait_for_samples_on_disk(out)
    os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert not (out / "manifest.json").exists()
    printed = re.search(r"Finish it with: (.+)$", stderr, re.M)
    assert printed, stderr
    options = f"--out {out} --workers 2 --seed {CONFIG.seed} --no-preview --resume"
    assert printed[1] == f"datagen build {_config_file(tmp_path)} {options}"
    _resume_and_compare(tmp_path, out, reference, printed[1])
