"""Bad input on the command line: one line naming the file, option or path and what was expected,
exit status 2, no traceback, nothing started and nothing the user had touched (issue 14)."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from datagen.cli import main
from datagen.config import BuildConfig
from datagen.errors import OutDirError
from datagen.pipeline.out_dir import BUILD_STATE, prepare_out_dir

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
CONFIG = str(REPO / "configs" / "grasp_tabletop.yaml")


def cli(*argv: str) -> tuple[int, str, str]:
    """``datagen ARGV`` in this process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse's errors
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def refused(result: tuple[int, str, str], *fragments: str) -> str:
    """The one error line of a refusal (status 2), checked to contain ``fragments``."""
    code, _, err = result
    assert code == 2, result
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    for fragment in fragments:
        assert fragment in line, line
    return line


def snapshot(root: Path) -> dict[str, str]:
    """Every path under ``root`` with its content's digest ('' for a directory)."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else ""
        for p in sorted(root.rglob("*"))
    }


# --- numbers ----------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["1e12", "1e3", "0", "-5", "2.0", "1000000000", "9" * 5000, ""])
def test_num_samples_is_a_whole_number_in_the_configs_range(tmp_path, value):
    result = cli("build", CONFIG, "--out", tmp_path / "out", "--num-samples", value)
    refused(result, "argument --num-samples: expected a whole number from 1 to 999999999")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("value", ["0", "1025", "many", "1e2"])
def test_workers_are_1_to_1024(tmp_path, value):
    result = cli("build", CONFIG, "--out", tmp_path, "--workers", value)
    refused(result, "argument --workers: expected a whole number from 1 to 1024")
    result = cli("campaign", "grasp", CONFIG, "--out", tmp_path, "--workers", value)
    refused(result, "argument --workers: expected a whole number from 1 to 1024")


def test_attempts_and_preview_count_are_bounded(tmp_path):
    result = cli("campaign", "grasp", CONFIG, "--out", tmp_path, "--attempts", "1e3")
    refused(result, "argument --attempts: expected a whole number from 1 to 999999999, got '1e3'")
    refused(cli("preview", tmp_path, "--count", "100000"), "expected a whole number from 1 to 256")


@pytest.mark.parametrize(
    ("option", "value", "expected"),
    [
        ("--broker", "http://user:secret@host", "bad broker URL 'http://user:***@host'"),
        ("--build-id", "a/b", "argument --build-id: expected 1-64 of [A-Za-z0-9_.-]"),
        ("--writers", "w1,w1", "argument --writers: expected comma-separated distinct ids"),
        ("--ca-file", "no-such-ca.pem", "argument --ca-file: no such file"),
        ("--seed", "-1", "argument --seed: expected a seed in [0, 2^63)"),
    ],
)
def test_service_options_are_checked_before_anything_starts(tmp_path, option, value, expected):
    line = refused(cli("build", CONFIG, "--out", tmp_path / "out", option, value), expected)
    assert "secret" not in line


# --- the output directory -----------------------------------------------------------------------


def test_out_naming_a_file_or_under_a_file_is_refused(tmp_path):
    file = tmp_path / "notes.txt"
    file.write_text("mine")
    refused(cli("build", CONFIG, "--out", file), f"{file}: exists and is not a directory")
    refused(
        cli("build", CONFIG, "--out", file / "sub" / "out"),
        f"{file / 'sub' / 'out'}: cannot be created: {file} is not a directory",
    )
    assert file.read_text() == "mine"


def test_out_where_no_file_can_be_created_is_refused():
    # /proc takes no new files, for root too (whom permission bits do not stop)
    refused(cli("build", CONFIG, "--out", "/proc/datagen-out"), "cannot create files in /proc")


@pytest.fixture
def read_only_dir(tmp_path):
    """A directory no file can be created in: mode 0555, or for root (whom modes do not stop) a
    read-only bind mount; skipped where neither works."""
    target = tmp_path / "read-only"
    target.mkdir()
    if os.geteuid() != 0:
        target.chmod(0o555)
        yield target
        target.chmod(0o755)
        return
    source = tmp_path / "source"
    source.mkdir()
    mount = ["mount", "--bind", "-o", "ro", str(source), str(target)]
    if not shutil.which("mount") or subprocess.run(mount, capture_output=True).returncode:
        pytest.skip("running as root where no read-only bind mount can be made")
    try:
        if os.access(target, os.W_OK):  # an old mount(8) ignored "ro" on a bind
            pytest.skip("the bind mount is not read-only")
        yield target
    finally:
        subprocess.run(["umount", str(target)], capture_output=True)


def test_out_on_a_read_only_directory_is_refused(read_only_dir):
    refused(
        cli("build", CONFIG, "--out", read_only_dir / "out"),
        f"{read_only_dir / 'out'}: cannot create files in {read_only_dir}",
    )
    refused(cli("build", CONFIG, "--out", read_only_dir), "cannot create files in")


def test_overwrite_refuses_a_directory_that_is_not_a_datagen_output(tmp_path):
    """The real command, without --check: the refusal comes before anything starts."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("four years of work")
    (out / "manifest.json").write_text('{"shards": [], "samples": 0}')  # not datagen's format
    before = snapshot(out)
    for command in (["build", "--num-samples", "1"], ["campaign", "grasp", "--attempts", "1"]):
        result = cli(*command, CONFIG, "--out", out, "--overwrite")
        line = refused(result, f"{out}: --overwrite deletes only a datagen output")
        assert "manifest.json, thesis.tex" in line and "left as it is" in line
    assert snapshot(out) == before


def fake_datagen_output(out: Path) -> Path:
    """What an interrupted build leaves: its build state, a shard, a journal."""
    out.mkdir()
    state = {"build_id": "b1", "secret": "00" * 32, "config": {"seed": 1}}
    (out / BUILD_STATE).write_text(json.dumps(state))
    (out / "shard-0-000000.tar").write_bytes(b"\0" * 1024)
    (out / ".writer-0.journal").write_text("{}\n")
    return out


def test_overwrite_replaces_a_datagen_output_or_an_empty_directory(tmp_path):
    config = BuildConfig().replace(num_samples=3)
    out = fake_datagen_output(tmp_path / "old")
    code, stdout, _ = cli("build", CONFIG, "--out", out, "--overwrite", "--check")
    assert code == 0 and "holds a datagen output that --overwrite would replace" in stdout
    identity, complete = prepare_out_dir(out, config, overwrite=True, resume=False, build_id=None)
    assert not complete and sorted(p.name for p in out.iterdir()) == [BUILD_STATE]
    assert json.loads((out / BUILD_STATE).read_text())["build_id"] == identity.build_id
    (tmp_path / "empty").mkdir()
    prepare_out_dir(tmp_path / "empty", config, overwrite=True, resume=False, build_id=None)
    assert (tmp_path / "empty" / BUILD_STATE).is_file()


def test_prepare_out_dir_never_deletes_what_a_build_did_not_make(tmp_path):
    out = tmp_path / "photos"
    out.mkdir()
    (out / "holiday.jpg").write_bytes(b"\xff\xd8 pixels")
    (out / BUILD_STATE).write_text('{"unrelated": true}')  # a file of the same name, not ours
    with pytest.raises(OutDirError, match=r"holds build\.json, holiday\.jpg and neither"):
        prepare_out_dir(out, BuildConfig(), overwrite=True, resume=False, build_id=None)
    assert (out / "holiday.jpg").read_bytes() == b"\xff\xd8 pixels"


def test_resume_errors_are_user_errors(tmp_path):
    refused(cli("build", CONFIG, "--out", tmp_path, "--resume"), "nothing to resume")
    out = fake_datagen_output(tmp_path / "other")
    refused(cli("build", CONFIG, "--out", out, "--resume"), "was started with another config")


# --- --check ------------------------------------------------------------------------------------


def test_check_validates_everything_and_starts_and_writes_nothing(tmp_path):
    code, stdout, err = cli("build", CONFIG, "--out", tmp_path / "new", "--check")
    assert code == 0, err
    assert stdout.startswith(f"datagen: check passed: {CONFIG}: the config and options are valid")
    code, stdout, err = cli("campaign", "grasp", CONFIG, "--out", tmp_path / "new", "--check")
    assert code == 0 and "check passed" in stdout, err
    assert os.listdir(tmp_path) == []
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects:\n  count: 3\n")
    code, _, err = cli("build", bad, "--out", tmp_path / "new", "--check")
    assert code == 2 and err == (
        f"datagen: config error: {bad}: objects.count: expected a [min, max] pair of whole "
        "numbers, e.g. [3, 12], got 3\n"
    )


def printed_command(tag: str) -> str:
    doc = (REPO / "docs" / "getting-started.md").read_text()
    found = re.search(rf"<!-- test: {re.escape(tag)} -->\n```bash\n([^\n]+)\n```", doc)
    assert found, f"docs/getting-started.md has no bash block tagged <!-- test: {tag} -->"
    return found[1]


def test_the_documented_check_command_runs_as_printed(tmp_path):
    command = printed_command("check")
    assert command.startswith("datagen build configs/") and command.endswith(" --check")
    (tmp_path / "configs").symlink_to(REPO / "configs")  # a fresh working directory
    bin_dir = Path(sys.executable).parent
    env = os.environ | {"PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    result = subprocess.run(
        ["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert "datagen: check passed:" in result.stdout
    assert sorted(os.listdir(tmp_path)) == ["configs"]  # nothing was created


# --- dataset directories ------------------------------------------------------------------------


def _corrupt(kind: str, root: Path, make_dataset, make_sample) -> Path:
    if kind == "missing":
        return root / "missing"
    if kind == "a file":
        (root / "file").write_text("x")
        return root / "file"
    if kind == "no manifest":
        (root / "empty").mkdir()
        return root / "empty"
    out = make_dataset(root / "ds", [make_sample(i) for i in range(4)], shard_size=2)
    manifest = json.loads((out / "manifest.json").read_text())
    shard = out / manifest["shards"][0]["name"]
    if kind == "not JSON":
        (out / "manifest.json").write_text('{"shards": [')
    elif kind == "shards of numbers":
        (out / "manifest.json").write_text(json.dumps(manifest | {"shards": [1, 2]}))
    elif kind == "samples not a count":
        (out / "manifest.json").write_text(json.dumps(manifest | {"samples": "many"}))
    elif kind == "shard outside":
        manifest["shards"][0]["name"] = "../../etc/passwd"
        (out / "manifest.json").write_text(json.dumps(manifest))
    elif kind == "truncated shard":
        shard.write_bytes(shard.read_bytes()[:1000])
    elif kind == "missing shard":
        shard.unlink()
    return out


CORRUPT = {
    "missing": "missing: no such directory; expected a dataset directory (with manifest.json)",
    "a file": "file: not a directory; expected a dataset directory",
    "no manifest": "empty is not a datagen dataset: no manifest.json",
    "not JSON": "manifest.json: not valid JSON",
    "shards of numbers": "manifest.json: shards[0]: expected a record with a 'name', got 1",
    "samples not a count": "manifest.json: 'samples' is 'many', expected a count",
    "shard outside": "shards[0]: 'name' is '../../etc/passwd', expected the file name of a shard",
    "truncated shard": "shard-0-000000.tar: 1000 bytes, the manifest lists",
    "missing shard": "shard shard-0-000000.tar listed in the manifest is missing",
}


@pytest.mark.parametrize("kind", CORRUPT)
@pytest.mark.parametrize(
    "command", [["inspect"], ["preview"], ["export", "--to", "coco"], ["replay", "000000000"]]
)
def test_dataset_commands_on_a_broken_directory_say_what_is_wrong(
    tmp_path, make_dataset, make_sample, kind, command
):
    path = _corrupt(kind, tmp_path, make_dataset, make_sample)
    before = snapshot(tmp_path)
    argv = [command[0], path, *command[1:]]
    line = refused(cli(*argv), f"datagen {command[0]}: error: ", CORRUPT[kind])
    assert str(path) in line
    assert snapshot(tmp_path) == before


def test_dataset_content_of_the_wrong_shape_is_a_user_error(tmp_path, make_dataset, make_sample):
    """Synthetic samples carry no metadata format: each command says so, and a failed export
    leaves nothing behind."""
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(2)])
    before = snapshot(out)
    refused(cli("inspect", out), f"{out}: unknown metadata format None")
    refused(cli("preview", out), "unknown metadata format None")
    refused(cli("export", out, "--to", "coco"), f"{out}: the dataset's content is not what")
    assert snapshot(out) == before
    refused(cli("preview", out, "--out", tmp_path / "grid.txt"), "expected a .png or .jpg")
