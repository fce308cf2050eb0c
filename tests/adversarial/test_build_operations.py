"""Build operations fail clearly (issue 22, medium findings): more workers than samples, a broker
port out of range or taken, ``--resume --overwrite``, ``--overwrite`` over the user's own files
in a datagen output, and a disk that fills mid-build. Each is done as a user would (the
command, a real listening socket, a real Mosquitto, a real small file system): one line, the
exit status, no traceback, nothing of the user's deleted."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from adversarial.test_cli_input import cli, refused, snapshot
from adversarial.tiny_build import REPO, N, build_command, journalled_samples, tiny_config
from datagen.config import BuildConfig
from datagen.dataset.loader import load, verify
from datagen.pipeline.out_dir import prepare_out_dir
from datagen.shards import MANIFEST

pytestmark = [pytest.mark.adversarial]
UNREACHABLE = "mqtt://127.0.0.1:1"  # so that a build the old code started fails at once


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_more_workers_than_samples_start_one_per_sample(tmp_path):
    out = tmp_path / "out"
    command = build_command(tiny_config(tmp_path), out, "--num-samples", "1", workers=8)
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    assert "with 1 workers (--workers 8: one per sample)" in result.stdout.splitlines()[0]
    assert json.loads((out / MANIFEST).read_text())["workers"] == 1


@pytest.mark.parametrize("port", ["99999", "0", "65536"])
def test_a_broker_port_out_of_range_is_refused(port):
    refused(
        cli("broker", "--port", port),
        f"argument --port: expected a whole number from 1 to 65535, got {int(port)}",
    )


def run_broker(port: int, *more: str, **env: str) -> subprocess.CompletedProcess:
    """``datagen broker --port PORT MORE...`` with ``env`` added to the environment."""
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", "broker", "--port", str(port), *more],
        cwd=REPO, capture_output=True, text=True, timeout=60, env=os.environ | env,
    )  # fmt: skip


def assert_taken(result: subprocess.CompletedProcess, port: int) -> None:
    assert result.returncode == 1 and "ready" not in result.stdout, result
    [line] = result.stderr.strip().splitlines()  # no log tail, no traceback
    assert f"127.0.0.1:{port} is already in use" in line, line


def test_a_broker_on_a_port_a_program_listens_on_fails_in_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert_taken(run_broker(port), port)


@pytest.mark.mqtt
def test_a_broker_on_the_port_of_another_broker_never_says_ready(broker):
    """The other broker takes the same user and password (a second ``datagen broker`` with the
    same --data-dir or options): it answers, yet it is not the one that was started."""
    result = run_broker(
        broker.port, "--username", broker.username, DATAGEN_BROKER_PASSWORD=broker.password
    )
    assert_taken(result, broker.port)


def datagen_output(out: Path) -> Path:
    """An interrupted build's directory: its state, a shard and its writer's journal."""
    prepare_out_dir(out, BuildConfig(), overwrite=False, resume=False, build_id=None)
    (out / "shard-0-000000.tar").write_bytes(b"\0" * 10240)
    (out / ".writer-0.journal").write_text("")
    return out


def test_resume_with_overwrite_is_refused_and_deletes_nothing(tmp_path):
    out = datagen_output(tmp_path / "out")
    before = snapshot(out)
    result = cli("build", tiny_config(tmp_path), "--out", out, "--resume", "--overwrite",
                 "--broker", UNREACHABLE)  # fmt: skip
    refused(result, f"{out}: --resume finishes the build in it, --overwrite deletes it")
    assert snapshot(out) == before


def test_overwrite_lists_the_users_files_in_a_datagen_output_and_deletes_nothing(tmp_path):
    out = datagen_output(tmp_path / "out")
    (out / "labels-by-hand.csv").write_text("key,label\n000000000,mug\n")
    (out / "notes").mkdir()
    (out / "notes" / "todo.txt").write_text("check the mugs")
    (out / "preview.png").write_bytes(b"\x89PNG")  # datagen's: no reason to keep it
    before = snapshot(out)
    result = cli("build", tiny_config(tmp_path), "--out", out, "--overwrite",
                 "--broker", UNREACHABLE)  # fmt: skip
    refused(
        result, "--overwrite would delete 2 files datagen did not write: labels-by-hand.csv, notes;"
    )
    assert snapshot(out) == before


@pytest.fixture
def small_disk(tmp_path) -> Iterator[Path]:
    """A 96 KiB tmpfs (the build state and about one sample of the tiny build), unmounted at
    the end; skipped where no tmpfs can be mounted (not root, or in a container without
    CAP_SYS_ADMIN)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mount = ["mount", "-t", "tmpfs", "-o", "size=96k", "tmpfs", str(disk)]
    if not shutil.which("mount") or subprocess.run(mount, capture_output=True).returncode:
        pytest.skip("cannot mount a small tmpfs here (needs root with CAP_SYS_ADMIN)")
    try:
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], capture_output=True)


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_disk_that_fills_mid_build_stops_it_in_one_line_and_resume_finishes_it(
    tmp_path, small_disk
):
    config, out = tiny_config(tmp_path), small_disk / "out"
    full = subprocess.run(
        build_command(config, out), cwd=REPO, capture_output=True, text=True, timeout=300
    )
    assert full.returncode == 1 and "Traceback" not in full.stderr, full.stderr
    failure = next(line for line in full.stderr.splitlines() if "build failed" in line)
    assert "disk full" in failure and str(out) in failure, full.stderr
    assert journalled_samples(out) >= 1  # the samples made durable before it filled stay
    subprocess.run(["mount", "-o", "remount,size=4m", str(small_disk)], check=True)
    resumed = subprocess.run(
        build_command(config, out, "--resume"), cwd=REPO, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    assert "were already durable" in resumed.stdout
    assert verify(out)["samples"] == N and len(load(out)) == N


def test_a_build_started_with_a_version_1_config_resumes_and_another_config_is_refused(tmp_path):
    from datagen.errors import OutDirError
    from datagen.pipeline.out_dir import BUILD_STATE, check_build_state

    config = BuildConfig()
    out = datagen_output(tmp_path / "out")
    state = json.loads((out / BUILD_STATE).read_text())
    output = state["config"]["output"]
    output["sinks"] = output.pop("formats")  # as datagen wrote it before config version 2
    state["config"]["version"] = 1
    (out / BUILD_STATE).write_text(json.dumps(state))
    check_build_state(out, config)  # the same config, recorded in version 1's words
    other = config.replace(num_samples=config.num_samples + 1)
    with pytest.raises(OutDirError, match=r"another config \(differs in: num_samples\)"):
        check_build_state(out, other)


def test_a_build_started_before_a_key_was_added_resumes_while_the_key_keeps_its_default(tmp_path):
    """A datagen that adds a config key (with a default) still resumes a build started by the
    one before it; a started config that no longer parses is refused as another config."""
    from datagen.errors import OutDirError
    from datagen.pipeline.out_dir import BUILD_STATE, check_build_state

    config = BuildConfig()
    out = datagen_output(tmp_path / "out")
    state = json.loads((out / BUILD_STATE).read_text())
    del state["config"]["campaign"]["check_reach"]  # as a datagen before the key wrote it
    (out / BUILD_STATE).write_text(json.dumps(state))
    check_build_state(out, config)
    with pytest.raises(OutDirError, match=r"another config \(differs in: campaign\)"):
        checking = dataclasses.replace(config.campaign, check_reach=True)
        check_build_state(out, config.replace(campaign=checking))
    state["config"]["campaign"]["friction"] = "slippery"
    (out / BUILD_STATE).write_text(json.dumps(state))
    with pytest.raises(OutDirError, match=r"another config \(differs in: campaign\)"):
        check_build_state(out, config)


def test_a_build_finished_before_a_key_was_added_is_kept_not_made_again(tmp_path):
    from datagen.errors import OutDirError
    from datagen.pipeline.out_dir import plan_out_dir

    config = BuildConfig()
    out = datagen_output(tmp_path / "out")
    recorded = config.to_dict()
    del recorded["campaign"]["check_reach"]  # as a datagen before the key wrote it
    manifest = {"config": recorded, "samples": config.num_samples}
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert plan_out_dir(out, config, overwrite=False, resume=False) == "complete"
    checking = dataclasses.replace(config.campaign, check_reach=True)
    with pytest.raises(OutDirError, match="does not hold a complete build of this config"):
        plan_out_dir(out, config.replace(campaign=checking), overwrite=False, resume=False)
