"""What a new user meets first: ``--version``, progress in a log file, the Ctrl-C hint that
resumes, a clear refusal of ``replay`` on navigation data, and benchmark scripts' ``--help``."""

from __future__ import annotations

import io
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

from datagen.cli import parser
from datagen.cli.build_commands import resume_command
from datagen.cli.progress import PlainProgress
from datagen.shards import write_json_durably

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent  # where the `datagen` script is installed


def datagen(*args, env=None, timeout=300):
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=timeout,
        env=env,
    )


def small_config(tmp_path: Path, formats: str = "[webdataset]") -> Path:
    config = tmp_path / "small.yaml"
    config.write_text(
        "scene: grasp_tabletop\nrender:\n  width: 96\n  height: 72\n"
        f"output:\n  shard_size: 2\n  formats: {formats}\n"
    )
    return config


def test_version_prints_the_package_version():
    from importlib import metadata

    result = datagen("--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout == f"datagen {metadata.version('datagen')}\n"


# --- progress when the output is not a terminal ---------------------------------------------------


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_plain_progress_prints_one_line_per_interval_and_one_at_the_end():
    out, clock = io.StringIO(), Clock()
    bar = PlainProgress(1000, "durable", stream=out, interval_s=10, clock=clock)
    for done in range(1, 1001):  # 1000 updates over 100 s
        clock.now = done * 0.1
        bar.update_to(done)
    bar.close()
    lines = out.getvalue().splitlines()
    assert 9 <= len(lines) <= 11, lines
    assert all(re.fullmatch(r"datagen: \d+/1000 durable, [\d.]+ samples/s, .+", x) for x in lines)
    assert re.fullmatch(r"datagen: \d+/1000 durable, 10\.0 samples/s, ETA 1m\d\ds", lines[0])
    assert lines[-1] == "datagen: 1000/1000 durable, 10.0 samples/s, in 1m40s"


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_build_into_a_log_file_prints_few_plain_progress_lines(tmp_path):
    config = small_config(tmp_path, formats="[webdataset, coco]")
    start = time.monotonic()
    result = datagen(
        "build", str(config), "--out", str(tmp_path / "out"), "--num-samples", "8",
        "--workers", "2", "--no-preview",
        env=os.environ | {"DATAGEN_PROGRESS_INTERVAL_S": "2"},
    )  # fmt: skip
    seconds = time.monotonic() - start
    assert result.returncode == 0, result.stderr
    assert "\r" not in result.stderr  # no bar redrawn into the file
    durable = [x for x in result.stderr.splitlines() if re.match(r"datagen: \d+/8 durable", x)]
    assert 1 <= len(durable) <= seconds / 2 + 2, result.stderr
    assert durable[-1].startswith("datagen: 8/8 durable, "), result.stderr
    exported = [x for x in result.stderr.splitlines() if "exported to coco" in x]
    assert exported and exported[-1].startswith("datagen: 8/8 exported to coco"), result.stderr


# --- Ctrl-C prints the command that resumes --------------------------------------------------------


def test_the_resume_command_repeats_every_option_given_and_hides_the_password(tmp_path):
    config, ca = tmp_path / "my configs" / "a.yaml", tmp_path / "ca.pem"
    config.parent.mkdir()
    config.write_text("scene: grasp_tabletop\n")
    ca.write_text("not checked here\n")
    args = parser().parse_args(
        ["-v", "build", str(config), "--out", str(tmp_path / "out dir"), "--num-samples", "40",
         "--seed", "7", "--workers", "3", "--broker", "mqtts://me:s3cret@host:8883",
         "--writers", "a,b", "--build-id", "b1", "--ca-file", str(ca), "--no-preview",
         "--executor", "ray", "--ray-address", "auto", "--overwrite"]
    )  # fmt: skip
    command = resume_command(args)
    assert "s3cret" not in command
    assert command.startswith(
        f"datagen -v build {shlex.quote(str(config))} --out {shlex.quote(str(tmp_path / 'out dir'))} "
        "--num-samples 40 --workers 3 --seed 7 --broker 'mqtts://me:***@host:8883' --writers a,b "
        f"--build-id b1 --ca-file {shlex.quote(str(ca))} --no-preview --executor ray "
        "--ray-address auto --resume"
    ), command
    assert shlex.split(command.partition(" --resume")[0])[3] == str(config)
    assert "--overwrite" not in command

    args = parser().parse_args(
        ["campaign", "grasp", "c.yaml", "--out", "o", "--attempts", "9", "--sampler", "random"]
    )
    assert resume_command(args) == (
        f"datagen campaign grasp c.yaml --attempts 9 --out o --sampler random "
        f"--workers {os.cpu_count() or 1} --resume"
    )
    args = parser().parse_args(["build", "c.yaml", "--out", "o"])  # defaults are not repeated...
    cores = os.cpu_count() or 1  # ...but for the workers, whose default is the number of cores
    assert resume_command(args) == f"datagen build c.yaml --out o --workers {cores} --resume"


# --- replay is for grasp scenes ----------------------------------------------------------------


def test_replay_on_a_navigation_dataset_says_it_is_grasp_only(tmp_path, make_dataset, make_sample):
    out = make_dataset(tmp_path / "nav", [make_sample(i) for i in range(2)])
    manifest = json.loads((out / "manifest.json").read_text())
    write_json_durably(out, manifest | {"scene": "navigation"})
    result = datagen("replay", str(out), "000000000")
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert "replay re-renders grasp samples only" in result.stderr
    assert "'navigation'" in result.stderr
    assert not list(out.glob("replay-*"))


# --- benchmark scripts: --help writes nothing ----------------------------------------------------


def _snapshot() -> dict[str, tuple[int, int]]:
    return {
        str(p): (p.stat().st_mtime_ns, p.stat().st_size)
        for folder in (REPO / "benchmarks" / "results", REPO / "docs" / "images")
        if folder.is_dir()
        for p in folder.rglob("*")
    }


@pytest.mark.parametrize("script", sorted(p.name for p in (REPO / "benchmarks").glob("*.py")))
def test_benchmark_help_prints_help_and_writes_nothing(script):
    before = _snapshot()
    result = subprocess.run(
        [sys.executable, f"benchmarks/{script}", "--help"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage:"), result.stdout
    assert _snapshot() == before
