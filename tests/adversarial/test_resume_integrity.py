"""Resume keeps nothing altered (issue 22, critical 3). A sample made durable and then changed
on disk (same size: a digit of its metadata; a corrupt PNG) before ``--resume`` is found by the
digest journalled when it was made durable, removed, made again from its (seed, index) and
named on the terminal; a sample changed before the finalize round never gets a manifest."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from adversarial.tiny_build import REPO, N, build_command, journalled_samples, tiny_config
from datagen.dataset.loader import load, verify
from datagen.shard_members import scan_members
from datagen.shards import MANIFEST
from datagen.transport.collector import AckCollector
from datagen.transport.publisher import SamplePublisher
from datagen.transport.wire import SECRET_ENV
from datagen.writer.dataset_writer import EXIT_FINALIZE_MISMATCH
from datagen.writer.journal import journal_path, recover
from datagen.writer.shard_writer import ShardWriter

pytestmark = [pytest.mark.adversarial]
TIMEOUT_S = 30


def alter(shard: Path, member: str, change: Callable[[bytes], bytes]) -> None:
    """Rewrites the tar member ``member`` of ``shard`` in place, keeping its size."""
    found = next(m for m in scan_members(shard) if m.name == member)
    with open(shard, "r+b") as f:
        f.seek(found.offset_data)
        old = f.read(found.size)
        new = change(old)
        assert len(new) == len(old) and new != old
        f.seek(found.offset_data)
        f.write(new)


def another_digit(data: bytes) -> bytes:
    """The first decimal digit replaced by the next one: still valid JSON, same size."""
    i = next(i for i, byte in enumerate(data) if chr(byte).isdigit())
    return data[:i] + str((int(chr(data[i])) + 1) % 10).encode() + data[i + 1 :]


def corrupt_png(data: bytes) -> bytes:
    """16 bytes of the compressed pixels inverted: a PNG whose chunk CRC fails."""
    middle = len(data) // 2
    return data[:middle] + bytes(b ^ 0xFF for b in data[middle : middle + 16]) + data[middle + 16 :]


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_resume_remakes_samples_changed_on_disk_since_they_were_made_durable(tmp_path):
    config, out = tiny_config(tmp_path), tmp_path / "out"
    build = subprocess.Popen(
        build_command(config, out),
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while journalled_samples(out) < 2:
        assert build.poll() is None and time.monotonic() < deadline, build.communicate()
        time.sleep(0.1)
    os.killpg(build.pid, signal.SIGINT)  # Ctrl-C: samples 0 and 1 at least are durable
    _, stderr = build.communicate(timeout=60)
    assert build.returncode == 130, stderr
    [shard] = out.glob("shard-*.tar")
    made = {key: load_parts(shard, key) for key in ("000000000", "000000001")}
    alter(shard, "000000000.json", another_digit)
    alter(shard, "000000001.rgb.png", corrupt_png)

    resumed = subprocess.run(
        build_command(config, out, "--resume"), cwd=REPO, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    assert "Traceback" not in resumed.stderr
    verify(out)
    dataset = load(out)
    assert dataset.keys == [f"{i:09d}" for i in range(N)]
    for key, parts in made.items():
        assert dataset.raw(int(key)) == parts, f"{key} is not the sample its (seed, index) makes"
    [line] = [line for line in resumed.stdout.splitlines() if "made again" in line]
    assert "made again 2 samples" in line and "000000000, 000000001" in line, line


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_finished_build_changed_on_disk_is_checked_and_made_again(tmp_path):
    """Issue 38, medium 12: ``--resume`` of a finished build said "nothing to do" and kept a
    sample changed on disk since; ``datagen verify`` found it."""
    config, out = tiny_config(tmp_path), tmp_path / "out"
    run(build_command(config, out))
    [shard] = out.glob("shard-*.tar")
    made = load_parts(shard, "000000001")
    alter(shard, "000000001.json", another_digit)
    changed = shard.read_bytes()

    again = run(build_command(config, out), expect=2)  # not told to resume: says what to run
    assert "000000001" in again.stderr and "--resume" in again.stderr, again.stderr
    checked = run(build_command(config, out, "--check", "--resume"))
    assert "would make them again" in checked.stdout and "000000001" in checked.stdout
    state, aside = out / "build.json", tmp_path / "build.json"
    state.rename(aside)  # the build's id and secret gone: nothing can be made again in place
    orphan = run(build_command(config, out, "--resume"), expect=2)
    assert "000000001" in orphan.stderr and "--overwrite" in orphan.stderr, orphan.stderr
    aside.rename(state)
    assert shard.read_bytes() == changed and (out / MANIFEST).is_file()  # refusals change nothing

    resumed = run(build_command(config, out, "--resume"))
    assert "nothing to do" not in resumed.stdout
    [line] = [line for line in resumed.stdout.splitlines() if "made again" in line]
    assert "made again 1 samples" in line and "000000001" in line, line
    verify(out)
    dataset = load(out)
    assert dataset.keys == [f"{i:09d}" for i in range(N)]
    assert dataset.raw(1) == made, "000000001 is not the sample its (seed, index) makes"
    assert "nothing to do" in run(build_command(config, out, "--resume")).stdout


def run(command: list[str], expect: int = 0) -> subprocess.CompletedProcess:
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == expect, done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    return done


def load_parts(shard: Path, key: str) -> dict[str, bytes]:
    """The parts of sample ``key`` as stored in ``shard``."""
    parts = {}
    with open(shard, "rb") as f:
        for m in scan_members(shard):
            if m.name.startswith(f"{key}."):
                f.seek(m.offset_data)
                parts[m.name[len(key) + 1 :]] = f.read(m.size)
    return parts


@pytest.mark.mqtt
def test_a_sample_changed_before_the_finalize_round_gets_no_manifest(
    broker, build_id, start_writer, make_sample, tmp_path, monkeypatch
):
    monkeypatch.delenv(SECRET_ENV, raising=False)  # a writer that checks no signature
    out = tmp_path / "ds"
    with AckCollector(broker.url, build_id) as collector:
        writer = start_writer(out=out, shard_size=10)
        collector.wait_status("ready", writer="0", timeout_s=TIMEOUT_S)
        with SamplePublisher(broker.url, build_id, "pub-" + build_id) as publisher:
            for i in range(3):
                publisher.publish(make_sample(i))
        assert collector.wait_acked(range(3), timeout_s=TIMEOUT_S), writer.log()[-3000:]
        [shard] = out.glob("shard-*.tar")
        alter(shard, "000000001.json", another_digit)  # durable and acknowledged, then changed
        status = collector.finalize(3, {}, timeout_s=TIMEOUT_S)
    assert status["state"] == "error", status
    assert f"{shard}: changed on disk" in status["reason"] and "000000001" in status["reason"]
    assert writer.wait() == EXIT_FINALIZE_MISMATCH and "Traceback" not in writer.log()
    assert not (out / MANIFEST).exists()
    recovered = recover(out, "0")  # as the writer of the resumed build does
    assert recovered.changed == ["000000001"]
    assert recovered.keys == {"000000000", "000000002"}


def test_samples_without_a_journalled_digest_are_not_kept(tmp_path, make_sample):
    """A journal an older datagen wrote (no digests): nothing says what these bytes should be,
    so recovery does not keep them and the build makes them again."""
    sink = ShardWriter(tmp_path, "0", 10)
    for i in range(2):
        sink.write(make_sample(i))
        sink.flush_durable()
    path = journal_path(tmp_path, "0")
    entries = [json.loads(line) for line in path.read_text().splitlines()]
    for entry in entries:
        del entry["sample_sha256"]
    path.write_text("".join(json.dumps(entry) + "\n" for entry in entries))
    recovered = recover(tmp_path, "0")
    assert recovered.changed == ["000000000", "000000001"] and recovered.keys == set()
    assert list(tmp_path.glob("shard-*.tar")) == []
