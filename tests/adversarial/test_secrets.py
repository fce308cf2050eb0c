"""Secrets stay secret: the broker password and the build secret never appear in what a build
prints or logs (at DEBUG too), in its errors, in the command line of any process it starts, or in
any file it writes but DIR/build.json; through a build that succeeds and builds that fail in
every way a user meets (wrong password, no broker, bad URL, bad config, bad secret, a worker's
error, Ctrl-C)."""

from __future__ import annotations

import os
import secrets
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from adversarial.leaks import (
    ProcessWatcher,
    environment,
    leaking_files,
    leaks,
    process_table,
    secret_forms,
)
from datagen.dataset.loader import check_complete
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.mosquitto import ManagedBroker

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
PLUGINS = REPO / "tests" / "plugins"
PASSWORD = "pw-" + secrets.token_hex(12)
SECRET = secrets.token_bytes(32)
TINY = """\
num_samples: 2
seed: 3
render: {width: 64, height: 48, wrist_camera: false}
objects: {count: [1, 1]}
physics: {settle_time: 0.1}
"""
FAILING_BLOCKS = """\
scene: example_blocks
num_samples: 3
seed: 7
render: {width: 64, height: 48}
build: {on_sample_error: fail}
"""


@dataclass
class Run:
    returncode: int
    output: str  # stdout and stderr
    processes: ProcessWatcher
    pid: int


def datagen(
    tmp_path: Path, args: list[str], env: dict[str, str], interrupt=None, timeout_s: float = 180
) -> Run:
    """Runs ``datagen -v ARGS`` (logs at DEBUG everywhere) while watching every process's
    command line; ``interrupt(pid)``, if given, returns once it is time for Ctrl-C."""
    log = tmp_path / f"run-{secrets.token_hex(3)}.log"
    env = os.environ | {"DATAGEN_LOG_LEVEL": "DEBUG", "PYTHONPATH": str(PLUGINS)} | env
    watcher = ProcessWatcher()
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "datagen.cli", "-v", *args],
            cwd=REPO,
            env={k: v for k, v in env.items() if v is not None},
            stdout=out,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            if interrupt is not None:
                interrupt(process.pid)
                os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C
            process.wait(timeout_s)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
            watcher.stop()
    return Run(process.returncode, log.read_text(errors="replace"), watcher, process.pid)


def assert_nothing_leaks(run: Run, out: Path, forms: dict[str, bytes], argv_ok=False) -> None:
    assert "Traceback" not in run.output, run.output[-3000:]
    assert not leaks(run.output, forms), run.output[-3000:]
    assert leaking_files(out, forms) == {}
    leaking = run.processes.leaking(forms)
    if argv_ok:  # the user's own command line holds what the user put there, and only it;
        # a child between fork and exec still shows that same command line, byte for byte
        users = {cmd for pid, cmd in run.processes.seen if pid == run.pid}
        leaking = {key: names for key, names in leaking.items() if key[1] not in users}
    assert leaking == {}


@pytest.fixture(scope="module")
def known_broker():
    """An external broker whose password the test knows."""
    with ManagedBroker(BrokerSettings(username="leak-test", password=PASSWORD)) as broker:
        yield broker


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_succeeding_build_leaks_nothing(tmp_path, known_broker):
    config, out = tmp_path / "tiny.yaml", tmp_path / "out"
    config.write_text(TINY)
    env = {"DATAGEN_BROKER_URL": known_broker.url, "DATAGEN_BUILD_SECRET": SECRET.hex()}
    run = datagen(tmp_path, ["build", str(config), "--out", str(out), "--workers", "1"], env)
    assert run.returncode == 0, run.output[-3000:]
    check_complete(out, 2)
    forms = secret_forms([PASSWORD], SECRET)
    assert_nothing_leaks(run, out, forms)
    # where the secret is by design, the same search finds it
    assert (out / "build.json").stat().st_mode & 0o777 == 0o600
    assert leaks((out / "build.json").read_bytes(), forms) == ["build secret (hex)"]
    started = run.processes.descendants(run.pid)
    assert any(" writer " in cmd and str(out) in cmd for cmd in started), started
    assert any("multiprocessing.spawn" in cmd for cmd in started), started  # a worker


def _wrong_password(url: str) -> tuple[str, list[str]]:
    wrong = "wrong-" + secrets.token_hex(8)
    return url.replace(PASSWORD, wrong), [wrong]


@pytest.mark.mqtt
@pytest.mark.parametrize(
    ("case", "exit_code", "says"),
    [
        ("wrong password", 1, "broker refused the credentials (user 'leak-test')"),
        pytest.param(
            "unreachable broker", 1, "cannot reach broker 127.0.0.1:", marks=pytest.mark.slow
        ),
        ("bad URL option", 2, "bad broker URL 'mqtt://leak-test:***@127.0.0.1:99999'"),
        ("bad URL variable", 2, "$DATAGEN_BROKER_URL: bad broker URL 'mqtt://leak-test:***@h'"),
        ("bad worker URL", 2, "$DATAGEN_WORKER_BROKER_URL: bad broker URL 'http://worker:***@h'"),
        ("worker URL alone", 2, "--worker-broker (or $DATAGEN_WORKER_BROKER_URL)"),
        ("config error", 2, "config error"),
        ("bad build secret", None, "DATAGEN_BUILD_SECRET must be hex digits"),
    ],
)
def test_a_build_refused_at_start_leaks_nothing(tmp_path, known_broker, case, exit_code, says):
    config, out = tmp_path / "tiny.yaml", tmp_path / "out"
    config.write_text(TINY + ("colour: red\n" if case == "config error" else ""))
    url, secret_hex, passwords = known_broker.url, SECRET.hex(), [PASSWORD]
    args = ["build", str(config), "--out", str(out), "--workers", "1"]
    env = {"DATAGEN_BROKER_URL": url, "DATAGEN_BUILD_SECRET": secret_hex}
    if case == "wrong password":
        env["DATAGEN_BROKER_URL"], passwords = _wrong_password(url)
    elif case == "unreachable broker":
        env["DATAGEN_BROKER_URL"] = f"mqtt://leak-test:{PASSWORD}@127.0.0.1:{_free_port()}"
    elif case == "bad URL option":  # on the command line: the user's choice, not ours to hide
        args += ["--broker", f"mqtt://leak-test:{PASSWORD}@127.0.0.1:99999"]
    elif case == "bad URL variable":
        env["DATAGEN_BROKER_URL"] = f"mqtt://leak-test:{PASSWORD}/x@h"
    elif case == "bad worker URL":
        env["DATAGEN_WORKER_BROKER_URL"] = f"http://worker:{PASSWORD}@h"
    elif case == "worker URL alone":
        env = {"DATAGEN_BROKER_URL": None, "DATAGEN_WORKER_BROKER_URL": url}
        env["DATAGEN_BUILD_SECRET"] = secret_hex
    elif case == "bad build secret":
        env["DATAGEN_BUILD_SECRET"] = secret_hex[:-1] + "g"
    run = datagen(tmp_path, args, env, timeout_s=60)
    assert run.returncode == exit_code if exit_code is not None else run.returncode in (1, 2)
    assert says in run.output, run.output[-3000:]
    forms = secret_forms(passwords, SECRET)
    if case == "bad build secret":
        forms["most of the secret"] = secret_hex[:-1].encode()
    assert_nothing_leaks(run, out, forms, argv_ok=case == "bad URL option")


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_workers_error_leaks_nothing(tmp_path, known_broker):
    config, out = tmp_path / "blocks.yaml", tmp_path / "out"
    config.write_text(FAILING_BLOCKS)
    env = {"DATAGEN_BROKER_URL": known_broker.url, "DATAGEN_BUILD_SECRET": SECRET.hex()}
    env["EXAMPLE_BLOCKS_FAIL"] = "1:99"
    run = datagen(tmp_path, ["build", str(config), "--out", str(out), "--workers", "1"], env)
    assert run.returncode == 1, run.output[-3000:]
    assert "injected fault in sample 1" in run.output
    assert_nothing_leaks(run, out, secret_forms([PASSWORD], SECRET))


@pytest.mark.mqtt
def test_ctrl_c_while_waiting_for_a_writer_hides_the_urls_in_the_resume_hint(
    tmp_path, known_broker
):
    config, out = tmp_path / "tiny.yaml", tmp_path / "out"
    config.write_text(TINY)
    worker_url = known_broker.url.replace("leak-test:", "worker-user:")
    args = ["build", str(config), "--out", str(out), "--writers", "never-started"]
    args += ["--broker", known_broker.url, "--worker-broker", worker_url]

    def when_waiting(pid: int) -> None:
        deadline = time.monotonic() + 30
        while not (out / "build.json").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(2)  # connected, and waiting for the writer

    env = {"DATAGEN_BUILD_SECRET": SECRET.hex()}
    run = datagen(tmp_path, args, env, interrupt=when_waiting)
    assert run.returncode == 130, run.output[-3000:]
    hint = run.output[run.output.index("Finish it with:") :]
    assert "--broker 'mqtt://leak-test:***@127.0.0.1:" in hint
    assert "--worker-broker 'mqtt://worker-user:***@127.0.0.1:" in hint and "--resume" in hint
    forms = secret_forms([PASSWORD], SECRET)
    assert_nothing_leaks(run, out, forms, argv_ok=True)
    # the watcher does see the user's argv (other pids with it: children between fork and exec)
    assert run.pid in {pid for pid, _ in run.processes.leaking(forms)}


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_ctrl_c_mid_build_on_a_private_broker_leaks_nothing(tmp_path):
    config, out = tmp_path / "tiny.yaml", tmp_path / "out"
    config.write_text(TINY.replace("num_samples: 2", "num_samples: 200"))
    learnt: list[str] = []

    def when_writing(pid: int) -> None:
        deadline = time.monotonic() + 120
        while not list(out.glob("shard-*.tar")) and time.monotonic() < deadline:
            for child, (_, cmdline) in process_table().items():
                if not learnt and " writer " in cmdline and str(out) in cmdline:
                    url = environment(child).get("DATAGEN_BROKER_URL")
                    learnt.extend([parse_broker_url(url).password] if url else [])
            time.sleep(0.2)
        time.sleep(1)

    run = datagen(tmp_path, ["build", str(config), "--out", str(out), "--workers", "1"],
                  {"DATAGEN_BROKER_URL": None, "DATAGEN_BUILD_SECRET": SECRET.hex()},
                  interrupt=when_writing)  # fmt: skip
    assert run.returncode == 130, run.output[-3000:]
    assert learnt, "the private broker's password was not found in its writer's environment"
    assert "Finish it with: datagen -v build" in run.output
    assert_nothing_leaks(run, out, secret_forms(learnt, SECRET))
    started = run.processes.descendants(run.pid)
    assert any("mosquitto -c" in cmd for cmd in started), started
