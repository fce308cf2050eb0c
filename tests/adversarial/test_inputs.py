"""Fuzz: mutated configs, mutated config files and mutated command lines (``build``,
``campaign grasp``, ``inspect``, ``preview``, ``export``) end in exit status 0 or 2 with one
clear line, never a traceback, and leave every directory that existed before as it was.

Nothing here starts a build: ``build`` and ``campaign grasp`` always run with ``--check``, which
validates the config, the options and ``--out`` and exits; the dataset commands get only broken
dataset directories, which they refuse before writing anything. No mocks: the real CLI runs
in this process (``datagen.cli.main``).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import json
import re
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from datagen.cli import main
from datagen.config import BuildConfig, config_from_dict, load_config
from datagen.errors import ConfigError

pytestmark = [pytest.mark.adversarial]

REPO = Path(__file__).resolve().parents[2]
CONFIG_FILES = sorted((REPO / "configs").glob("*.yaml"))
# the configs as users start from them, and one with every key
BASES: dict[str, dict[str, Any]] = {
    p.name: yaml.safe_load(p.read_text()) or {} for p in CONFIG_FILES
} | {"defaults": BuildConfig().to_dict()}

FUZZ = settings(
    max_examples=200,
    deadline=None,
    database=None,  # writes nothing into the repository (.hypothesis/)
    suppress_health_check=[HealthCheck.too_slow],
)

# what a user or a broken file could put in place of a value
NASTY_VALUES = st.one_of(
    st.sampled_from(
        [
            *(float("nan"), float("inf"), -float("inf"), 10**30, -(10**30), 2**63, -1, 0, 0.5),
            *(True, False, None, "", "box", "nan", "1e3", "[1, 2]", [], {}, [1], [1, 2, 3]),
            *([[1, 2]], [None, None], ["a", "b"], {"min": 1, "max": 2}, "webdataset", -0.0),
        ]
    ),
    st.integers(),
    st.floats(),
    st.text(max_size=12),
    st.lists(st.one_of(st.integers(), st.floats(), st.text(max_size=4)), max_size=4),
    st.dictionaries(st.text(max_size=6), st.integers(), max_size=3),
)
KEY_NAMES = st.one_of(
    st.text(min_size=1, max_size=12), st.sampled_from(["colour", "count ", "Seed", "objects"])
)


def _paths(tree: dict, prefix: tuple = ()) -> list[tuple]:
    """Every key path into the nested mappings of ``tree``."""
    found = []
    for key, value in tree.items():
        found.append((*prefix, key))
        if isinstance(value, dict):
            found.extend(_paths(value, (*prefix, key)))
    return found


def _nasty(data: st.DataObject) -> Any:
    """A nasty value, copied: the lists and mappings of NASTY_VALUES are shared objects, and a
    later mutation of this config must not change them for the next example (hypothesis then
    sees other data for the same choices and reports the test as flaky)."""
    return copy.deepcopy(data.draw(NASTY_VALUES, "value"))


def mutated_config(data: st.DataObject) -> dict[str, Any]:
    """A config from ``BASES`` with 1-4 mutations: a key deleted, renamed or added, a value
    replaced by a nasty one, wrapped in a list or a mapping, or scaled out of range."""
    config = copy.deepcopy(data.draw(st.sampled_from(list(BASES.values())), "base"))
    for _ in range(data.draw(st.integers(1, 4), "mutations")):
        paths = _paths(config)
        if not paths:
            config[data.draw(KEY_NAMES)] = _nasty(data)
            continue
        path = data.draw(st.sampled_from(paths), "path")
        parent = config
        for key in path[:-1]:
            parent = parent[key]
        key = path[-1]
        op = data.draw(st.sampled_from(["delete", "replace", "rename", "add", "wrap", "scale"]))
        if op == "delete":
            del parent[key]
        elif op == "replace":
            parent[key] = _nasty(data)
        elif op == "rename":
            parent[data.draw(KEY_NAMES, "new name")] = parent.pop(key)
        elif op == "add":
            parent[data.draw(KEY_NAMES, "key")] = _nasty(data)
        elif op == "wrap":
            parent[key] = data.draw(st.sampled_from([[parent[key]], {"value": parent[key]}]))
        elif isinstance(parent[key], int | float) and not isinstance(parent[key], bool):
            parent[key] *= data.draw(st.sampled_from([-1, 1000, 10**12, 0.5, float("inf")]))
    return config


def assert_one_clear_line(exc: ConfigError, source: str) -> None:
    message = str(exc)
    assert message.startswith(f"{source}: "), message
    assert "\n" not in message and len(message) < 1500, message


@FUZZ
@given(data=st.data())
def test_mutated_configs_are_valid_or_one_clear_error(data):
    config = mutated_config(data)
    try:
        result = config_from_dict(config, source="fuzz.yaml")
    except ConfigError as exc:
        assert_one_clear_line(exc, "fuzz.yaml")
    else:
        assert config_from_dict(result.to_dict()) == result  # a valid config round-trips


@FUZZ
@given(data=st.data())
def test_mutated_config_files_are_valid_or_one_clear_error(data, tmp_path_factory):
    """The same through a YAML file, and files whose bytes were damaged."""
    path = tmp_path_factory.mktemp("fuzz") / "config.yaml"
    if data.draw(st.booleans(), "damage bytes"):
        raw = bytearray(data.draw(st.sampled_from(CONFIG_FILES)).read_bytes())
        for _ in range(data.draw(st.integers(1, 8))):
            at = data.draw(st.integers(0, len(raw)))
            raw[at:at] = data.draw(st.binary(min_size=1, max_size=4))
            del raw[data.draw(st.integers(0, len(raw) - 1))]
        path.write_bytes(bytes(raw))
    else:
        path.write_text(yaml.safe_dump(mutated_config(data), allow_unicode=True))
    start = time.monotonic()
    try:
        load_config(path)
    except ConfigError as exc:
        assert_one_clear_line(exc, str(path))
    assert time.monotonic() - start < 1.0


# --- command lines ---------------------------------------------------------------------------


def _broken_datasets(root: Path) -> list[Path]:
    """Directories that look a bit like datasets, each broken in another way."""
    made = []
    for name, manifest in [
        ("not-json", '{"shards": ['),
        ("wrong-types", json.dumps({"samples": "x", "shards": [1, {"name": 5}]})),
        ("outside", json.dumps({"samples": 1, "shards": [{"name": "../../etc/passwd"}]})),
        ("truncated", json.dumps({"samples": 2, "shards": [{"name": "s.tar", "bytes": 20480}]})),
        ("missing-shard", json.dumps({"samples": 2, "shards": [{"name": "gone.tar"}]})),
        ("no-manifest", None),
    ]:
        directory = root / "datasets" / name
        directory.mkdir(parents=True)
        if manifest is not None:
            (directory / "manifest.json").write_text(manifest)
        made.append(directory)
    (root / "datasets" / "truncated" / "s.tar").write_bytes(b"\0" * 700)
    return made


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> dict[str, list[str]]:
    """Files and directories the command lines name, by role."""
    root = tmp_path_factory.mktemp("workspace")
    (root / "mine").mkdir()
    (root / "mine" / "thesis.tex").write_text("four years of work")
    (root / "empty").mkdir()
    (root / "interrupted").mkdir()
    state = {"build_id": "b1", "secret": "00" * 32, "config": {"seed": 1}}
    (root / "interrupted" / "build.json").write_text(json.dumps(state))
    (root / "interrupted" / "shard-0-000000.tar").write_bytes(b"\0" * 1024)
    (root / "a-file").write_text("x")
    (root / "binary.yaml").write_bytes(b"\xff\xfe\x00\x01")
    bomb = "".join(
        f"  - &a{i} [{', '.join([f'*a{i - 1}'] * 9) if i else 'lol'}]\n" for i in range(10)
    )
    (root / "bomb.yaml").write_text(f"output:\n  formats:\n{bomb}")
    (root / "generated").mkdir()  # the one place examples write: their mutated configs
    datasets = [str(p) for p in _broken_datasets(root)]
    places = [str(root / n) for n in ("mine", "empty", "interrupted", "a-file", "missing")]
    return {
        "root": [str(root)],
        "configs": [str(p) for p in CONFIG_FILES]
        + [str(root / n) for n in ("binary.yaml", "bomb.yaml", "empty", "missing.yaml")],
        "outs": [*places, str(root / "a-file" / "out"), str(root / "new" / "out"), "/proc/x"],
        "datasets": [*datasets, *places],
        "files": [str(root / "a-file"), str(root / "missing.pem"), str(CONFIG_FILES[0])],
    }


def snapshot(root: Path) -> dict[str, str]:
    """Every path under ``root`` but ``generated/``, with its content's digest."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else ""
        for p in sorted(root.rglob("*"))
        if p.relative_to(root).parts[0] != "generated"
    }


NUMBERS = st.one_of(
    st.sampled_from(["0", "1", "2", "-1", "1e3", "1e12", "999999999", "1000000000", "3.0"]),
    st.sampled_from(["", " 3", "nan", "inf", "0x10", "1_000", "9" * 50, "9" * 5000]),
    st.integers(-(2**70), 2**70).map(str),
)
TEXT = st.text(st.characters(blacklist_characters="\x00"), max_size=16)  # argv holds no NUL


def options(data: st.DataObject, workspace: dict, command: str) -> list[str]:
    """Options of ``command``, each present or not, with plausible or nasty values."""
    pick = lambda role: data.draw(st.one_of(st.sampled_from(workspace[role]), TEXT))  # noqa: E731
    pool: dict[str, Any] = {}
    if command in ("build", "campaign"):
        pool = {
            "--out": lambda: pick("outs"),
            "--seed": lambda: data.draw(NUMBERS),
            "--workers": lambda: data.draw(NUMBERS),
            "--overwrite": None,
            "--resume": None,
        }
    if command == "build":
        pool |= {
            "--num-samples": lambda: data.draw(NUMBERS),
            "--broker": lambda: data.draw(
                st.one_of(
                    st.sampled_from(["mqtt://h:1883", "mqtts://u:p@h", "mqtt://h:99999"]), TEXT
                )
            ),
            "--writers": lambda: data.draw(st.sampled_from(["0", "0,1", "0,0", "", "a b"])),
            "--build-id": lambda: data.draw(st.one_of(st.just("b-1"), TEXT)),
            "--ca-file": lambda: pick("files"),
            "--no-preview": None,
            "--executor": lambda: data.draw(st.sampled_from(["local", "ray", "slurm"])),
            "--ray-address": lambda: data.draw(st.sampled_from(["auto", "ray://h:1", ""])),
        }
    if command == "campaign":
        pool |= {
            "--attempts": lambda: data.draw(NUMBERS),
            "--sampler": lambda: data.draw(st.sampled_from(["antipodal", "random", "magic"])),
        }
    if command == "preview":
        pool = {"--out": lambda: pick("outs") + ".png", "--count": lambda: data.draw(NUMBERS)}
    if command == "export":
        formats = st.sampled_from(["coco", "hdf5", "coco,usd", "", "jpeg", "coco,,hdf5"])
        pool = {"--to": lambda: data.draw(formats), "--force": None}
    argv = []
    for flag, value in pool.items():
        if data.draw(st.booleans(), flag):
            argv += [flag] if value is None else [flag, value()]
    if data.draw(st.integers(0, 9)) == 0:
        argv.append(data.draw(st.sampled_from(["--bogus", "-x", "--out", "--check=yes"])))
    return argv


ERROR_LINE = re.compile(r"^datagen[\w ]*: (config )?error: .")


def run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's errors and --help
            code = exc.code
    return code, out.getvalue(), err.getvalue()


@FUZZ
@given(data=st.data())
def test_mutated_command_lines_exit_0_or_2_and_touch_nothing(data, workspace):
    root = Path(workspace["root"][0])
    command = data.draw(st.sampled_from(["build", "campaign", "inspect", "preview", "export"]))
    argv = ["-v"] if data.draw(st.integers(0, 4)) == 0 else []
    if command in ("build", "campaign"):
        config = data.draw(st.sampled_from([*workspace["configs"], "generated"]), "config")
        if config == "generated":
            config = str(root / "generated" / "config.yaml")
            Path(config).write_text(yaml.safe_dump(mutated_config(data), allow_unicode=True))
        argv += ["build"] if command == "build" else ["campaign", "grasp"]
        argv += [config, *options(data, workspace, command), "--check"]  # never a build
    else:
        dataset = data.draw(st.one_of(st.sampled_from(workspace["datasets"]), TEXT), "dataset")
        argv += [command, dataset, *options(data, workspace, command)]
    before = snapshot(root)
    code, stdout, stderr = run(argv)
    assert code in (0, 2), (argv, code, stderr)
    assert "Traceback" not in stderr + stdout, (argv, stderr)
    if code == 2:
        assert ERROR_LINE.match(stderr.strip().splitlines()[-1]), (argv, stderr)
    else:
        assert command in ("build", "campaign") and "datagen: check passed: " in stdout, argv
    assert snapshot(root) == before, argv
