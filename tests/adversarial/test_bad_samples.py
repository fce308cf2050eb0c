"""One sample whose metadata cannot be drawn or summarised (NaN, infinite or zero intrinsics, a
NaN pose, a box 10^12 pixels wide, JSON nested 10 000 deep) is reported by key and skipped by
``datagen inspect`` and ``datagen preview``: the others are drawn, exit status 0; a dataset with
no drawable sample is one line and exit status 2 (issue 22, high 8).

The datasets hold real grasp samples (``grasp_dataset``) with one sample's JSON edited, read by
the real CLI (``datagen.cli.main`` in this process)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from adversarial.grasp_dataset import cli, grasp_samples, metadata, with_json, write_grasp_dataset

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]

BAD_KEY = "000000001"
INF = "__infinite__"  # replaced by the JSON number 1e999, which Python reads as inf


def _set_intrinsics(value: Any) -> Callable[[dict], None]:
    def edit(meta: dict) -> None:
        meta["views"]["workspace"]["camera"]["intrinsics"] = value

    return edit


def _visible(meta: dict) -> dict:
    return next(o for o in meta["views"]["workspace"]["objects"] if o["visible"])


def _pose(value: Any) -> Callable[[dict], None]:
    def edit(meta: dict) -> None:
        _visible(meta)["pose_camera"]["matrix"] = [[value] * 4] * 4

    return edit


def _huge_box(meta: dict) -> None:
    _visible(meta)["bbox_xyxy"] = [0, 0, 10**12, 10**12]


def _deep(meta: dict) -> None:
    meta["randomisation"]["nested"] = INF  # a marker, replaced below


EDITS: dict[str, Callable[[dict], None]] = {
    "NaN intrinsics": _set_intrinsics([[float("nan")] * 3] * 3),
    "infinite intrinsics": _set_intrinsics([[INF, 0, 32], [0, INF, 24], [0, 0, 1]]),
    "zero intrinsics": _set_intrinsics([[0, 0, 0], [0, 0, 0], [0, 0, 0]]),
    "NaN pose": _pose(float("nan")),
    "infinite pose": _pose(INF),
    "huge box": _huge_box,
    "JSON 10000 deep": _deep,
}


def bad_json(kind: str, meta: dict) -> str:
    EDITS[kind](meta)
    text = json.dumps(meta)  # NaN is written as NaN, as json.dumps does by default
    if kind == "JSON 10000 deep":
        return text.replace(f'"{INF}"', "[" * 10_000 + "]" * 10_000)
    return text.replace(f'"{INF}"', "1e999")


@pytest.fixture
def dataset_with(tmp_path, make_dataset) -> Callable[[dict[str, str]], Path]:
    """A dataset of the two real samples, with the JSON of the keys given replaced."""

    def make(replaced: dict[str, str]) -> Path:
        samples = [
            with_json(s, replaced[s.key]) if s.key in replaced else s for s in grasp_samples()
        ]
        return write_grasp_dataset(tmp_path / "ds", samples, make_dataset)

    return make


def assert_reports_only(err: str, key: str) -> None:
    """stderr: one line per skipped sample, naming it; nothing else (no traceback, no warning)."""
    lines = err.strip().splitlines()
    assert lines and all(line.startswith("datagen ") for line in lines), err
    assert any(f"sample {key} skipped" in line for line in lines), err
    assert "Traceback" not in err


@pytest.mark.parametrize("kind", EDITS)
def test_preview_skips_the_bad_sample_and_draws_the_others(dataset_with, kind):
    out = dataset_with({BAD_KEY: bad_json(kind, metadata(grasp_samples()[1]))})
    code, printed, err = cli("preview", out)
    assert code == 0, err
    assert_reports_only(err, BAD_KEY)
    assert (out / "preview.png").stat().st_size > 0 and "wrote" in printed


@pytest.mark.parametrize("kind", ["infinite intrinsics", "NaN pose", "huge box", "JSON 10000 deep"])
def test_inspect_skips_the_bad_sample_and_summarises_the_others(dataset_with, kind):
    out = dataset_with({BAD_KEY: bad_json(kind, metadata(grasp_samples()[1]))})
    code, _, err = cli("inspect", out)
    assert code == 0, err
    assert_reports_only(err, BAD_KEY)
    summary = json.loads((out / "inspect" / "summary.json").read_text())
    assert summary["samples"] == len(grasp_samples()) - 1 and summary["skipped_samples"] == 1
    for name in ("overview.png", "distributions.png", "randomisation.png"):
        assert (out / "inspect" / name).stat().st_size > 0


def test_an_unreadable_first_sample_does_not_decide_the_format(dataset_with):
    deep = "[" * 10_000 + "]" * 10_000
    out = dataset_with({"000000000": deep})
    code, _, err = cli("inspect", out)
    assert code == 0, err
    assert_reports_only(err, "000000000")


def test_a_dataset_of_bad_samples_is_one_line_and_exit_2(dataset_with):
    samples = grasp_samples()
    out = dataset_with({s.key: bad_json("huge box", metadata(s)) for s in samples})
    for command in ("preview", "inspect"):
        code, _, err = cli(command, out)
        assert code == 2, err
        assert "Traceback" not in err
        last = err.strip().splitlines()[-1]
        assert last.startswith(f"datagen {command}: error: {out}: no sample"), last
        assert "bbox_xyxy" in last, last
