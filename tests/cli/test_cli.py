"""The command line as a user meets it: help, clear errors without tracebacks, clean Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from conftest import descendants_running  # tests/conftest.py: a test's own processes

REPO = Path(__file__).resolve().parents[2]


def datagen(*args, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
        **kwargs,
    )


def test_help_lists_every_command():
    result = datagen("--help")
    assert result.returncode == 0
    for command in ("build", "preview"):
        assert command in result.stdout
    assert "--workers" in datagen("build", "--help").stdout


def test_bad_config_is_a_clear_error_without_traceback(tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text("objects:\n  count: [1, 2]\n  colour: red\n")
    result = datagen("build", str(config), "--out", str(tmp_path / "out"))
    assert result.returncode == 2
    assert f"{config}: unknown key(s) objects.colour" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_bad_arguments_are_clear_errors(tmp_path):
    result = datagen(
        "build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path), "--workers", "0"
    )
    assert (
        result.returncode == 2 and "expected a whole number from 1 to 1024, got 0" in result.stderr
    )
    result = datagen("build", "configs/nope.yaml", "--out", str(tmp_path))
    assert result.returncode == 2 and "no such config file" in result.stderr


def test_non_empty_output_directory_is_refused(tmp_path):
    (tmp_path / "something.txt").write_text("mine")
    result = datagen(
        "build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path), "--num-samples", "2"
    )
    assert result.returncode == 2
    assert "is not empty" in result.stderr and "Traceback" not in result.stderr
    assert (tmp_path / "something.txt").read_text() == "mine"


def test_the_resume_hint_hides_the_password_of_both_broker_urls():
    from datagen.cli import parser
    from datagen.cli.build_commands import resume_command

    args = parser().parse_args(
        ["build", "c.yaml", "--out", "o", "--broker", "mqtt://coordinator:pw-1@h:1883",
         "--worker-broker", "mqtt://worker:pw-2@h:1883", "--writers", "A"]
    )  # fmt: skip
    hint = resume_command(args)
    assert "pw-1" not in hint and "pw-2" not in hint
    assert "--broker 'mqtt://coordinator:***@h:1883'" in hint
    assert "--worker-broker 'mqtt://worker:***@h:1883'" in hint


def test_worker_broker_without_a_broker_is_refused(tmp_path):
    result = datagen(
        "build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path / "o"),
        "--worker-broker", "mqtt://worker:pw-2@h:1883", "--check",
        env={k: v for k, v in os.environ.items() if k != "DATAGEN_BROKER_URL"},
    )  # fmt: skip
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--worker-broker (or $DATAGEN_WORKER_BROKER_URL)" in result.stderr
    assert "pw-2" not in result.stderr + result.stdout


def test_the_resume_hint_repeats_each_sample_broker_without_its_password():
    from datagen.cli import parser
    from datagen.cli.build_commands import resume_command

    args = parser().parse_args(
        ["build", "c.yaml", "--out", "o", "--broker", "mqtt://c:pw-1@h:1883",
         "--sample-broker", "mqtt://c:pw-1@h:1883", "--sample-broker", "mqtt://s:pw-3@g:1884",
         "--writers", "A,B"]
    )  # fmt: skip
    hint = resume_command(args)
    assert "pw-1" not in hint and "pw-3" not in hint
    assert "--sample-broker 'mqtt://c:***@h:1883' --sample-broker 'mqtt://s:***@g:1884'" in hint


@pytest.mark.parametrize(
    ("given", "says"),
    [
        (["--sample-broker", "mqtt://s:pw-3@g:1884"], "1 sample brokers (--sample-broker or"),
        (["--broker", "mqtt://c:pw-1@h:1883", "--sample-broker", "mqtt://s:pw-3@g:1884"],
         "a writer set per sample broker"),
        (["--sample-broker", "http://s:pw-3@g:1884"], "bad broker URL 'http://s:***@g:1884'"),
    ],
)  # fmt: skip
def test_sample_brokers_without_a_broker_or_writers_are_refused(tmp_path, given, says):
    result = datagen(
        "build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path / "o"), *given, "--check",
        env={k: v for k, v in os.environ.items() if not k.startswith("DATAGEN_")},
    )  # fmt: skip
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert says in result.stderr, result.stderr
    assert "pw-" not in result.stderr + result.stdout


def test_a_writer_given_a_bad_sample_broker_says_so_in_one_line(tmp_path):
    result = datagen(
        "writer", "--build-id", "b", "--out", str(tmp_path / "o"),
        "--broker", "mqtt://c:pw-1@127.0.0.1:1", "--sample-broker", "http://s:pw-3@g:1884",
    )  # fmt: skip
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert "--sample-broker" in result.stderr and "pw-3" not in result.stderr
    assert not (tmp_path / "o").exists()


def _children_named(name: str) -> list[str]:
    out = subprocess.run(["pgrep", "-f", name], capture_output=True, text=True).stdout
    return out.split()


def _alive(process: psutil.Process) -> bool:
    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_ctrl_c_stops_the_build_cleanly(tmp_path):
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "datagen.cli",
            "build",
            "configs/grasp_tabletop.yaml",
            "--out",
            str(tmp_path / "out"),
            "--num-samples",
            "500",
            "--workers",
            "2",
        ],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list((tmp_path / "out").glob("*.tar")):
        time.sleep(0.5)
    time.sleep(2)
    brokers = descendants_running("mosquitto", process.pid)
    assert brokers, "the build runs no Mosquitto of its own"
    os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr
    assert not (tmp_path / "out" / "manifest.json").exists()
    time.sleep(1)
    assert not [broker.pid for broker in brokers if _alive(broker)]
    assert _children_named(str(tmp_path / "out")) == []  # the writer is gone too
