"""``datagen replay`` on a USD description that is not the one datagen wrote: truncated, not USD,
binary garbage or a crate file under the ``.usda`` name, one that makes usd-core open other files
(a sublayer, a reference, value clips), custom data nested 10 000 deep or not the sample's. Each
is one line naming the file and exit status 2, never a ``pxr`` traceback, and nothing but the
stage is read (issue 22, high 8). Then Hypothesis mutates the stage (text edits, numbers made
NaN or 1e300, the custom data replaced) and checks the same of the stage reading itself.

The stages come from real grasp samples (``grasp_dataset``) exported by ``datagen export --to
usd``; the commands are the real CLI in this process."""

from __future__ import annotations

import itertools
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import write_dataset  # tests/conftest.py: shards and a manifest, no MQTT
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adversarial.grasp_dataset import cli, grasp_samples, metadata, usd_dataset
from datagen.dataset.loader import DatasetError
from datagen.tools.replay import MAX_REACH, stored_description

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
KEY = "000000000"


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    return usd_dataset(tmp_path_factory.mktemp("replay") / "ds", write_dataset)


@pytest.fixture
def dataset(exported, tmp_path) -> Path:
    """A fresh copy of the exported dataset (its stage is edited by the test)."""
    import shutil

    return Path(shutil.copytree(exported, tmp_path / "ds"))


def _sublayer(text: str) -> str:
    return text.replace("(\n", "(\n    subLayers = [@./000000001.usda@]\n", 1)


def _reference(text: str) -> str:
    return text.replace('def Xform "World" (\n', 'def Xform "World" (\n    prepend references = @/etc/hosts@\n', 1)  # fmt: skip


def _clips(text: str) -> str:
    clips = 'clips = {\n dictionary default = {\n asset[] assetPaths = [@./elsewhere.usdc@]\n string primPath = "/X"\n }\n }'  # fmt: skip
    return text.replace('def Xform "World" (\n', f'def Xform "World" (\n    {clips}\n', 1)


def _deep_custom_data(text: str) -> str:
    return re.sub(r"string randomisation = '.*'", "string randomisation = '" + "[" * 10_000 + "]" * 10_000 + "'", text)  # fmt: skip


def _other_randomisation(text: str) -> str:
    return text.replace('"ceiling": true', '"ceiling": false', 1)


# how the stage is broken -> (its new bytes from the stage's text, what the one line says)
BROKEN = {
    "truncated": (lambda t: t[: len(t) // 2].encode(), "usd-core cannot read it"),
    "a text file": (lambda t: b"#usda is what this file is not\n", "usd-core cannot read it"),
    "plain text": (lambda t: b"hello\n", "expected a text USD stage"),
    "binary garbage": (lambda t: np.random.default_rng(0).bytes(5000), "expected a text USD stage"),
    "a crate file": (
        lambda t: b"PXR-USDC" + np.random.default_rng(1).bytes(5000),
        "expected a text USD stage",
    ),
    "a sublayer": (lambda t: _sublayer(t).encode(), "refers to other files"),
    "a reference to /etc/hosts": (
        lambda t: _reference(t).encode(),
        "refers to other files (/etc/hosts)",
    ),
    "value clips": (lambda t: _clips(t).encode(), "value clips on /World"),
    "custom data 10000 deep": (
        lambda t: _deep_custom_data(t).encode(),
        "datagen:randomisation: JSON nested deeper",
    ),
    "another sample's values": (
        lambda t: _other_randomisation(t).encode(),
        "is not the sample's",
    ),
}


@pytest.mark.parametrize("kind", BROKEN)
def test_replay_of_a_broken_stage_is_one_line_naming_it(dataset, kind):
    stage = dataset / "usd" / f"{KEY}.usda"
    make, says = BROKEN[kind]
    stage.write_bytes(make(stage.read_text()))
    code, _, err = cli("replay", dataset, KEY)
    assert code == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("datagen")]
    assert len(lines) == 1 and lines[0].startswith(f"datagen replay: error: {stage}: "), err
    assert says in lines[0], lines[0]
    assert not list(dataset.glob("replay-*"))


def test_a_fifo_in_place_of_the_stage_is_refused_without_reading_it(dataset):
    stage = dataset / "usd" / f"{KEY}.usda"
    stage.unlink()
    os.mkfifo(stage)  # opening it to read would wait for a writer for ever
    code, _, err = cli("replay", dataset, KEY)
    assert code == 2 and "expected a text USD stage" in err and "got no regular file" in err, err


# --- Hypothesis: the stage reading on mutated stages --------------------------------------------

FUZZ = settings(
    max_examples=60,  # about 0.6 s each: usd-core reads a stage
    deadline=None,
    database=None,  # writes nothing into the repository (.hypothesis/)
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
TOKENS = [
    *("(", ")", "{", "}", "[", "]", '"', "'", "@", "=", ",", "\\", "\n", "\x00", "\udcff"),
    *("nan", "inf", "-inf", "1e300", "1e999", "9" * 400, 'def Xform "A" {\n', "over ", "class "),
    *("custom ", "dictionary ", "string ", "double3 ", "uniform token[] ", "rel a = </World>\n"),
    *("prepend references = @./x.usda@\n", "subLayers = [@/dev/zero@]\n", "#usda 1.0\n"),
    'dictionary datagen = { string randomisation = "[]" }\n',
]
NASTY_NUMBERS = ["nan", "inf", "-inf", "1e300", "-1e308", "1e999", "0", "-0", "1e-320"]
NUMBER = re.compile(r"-?\d+\.?\d*(?:e-?\d+)?")
# the numbers replay reads from the stage itself: transforms and the robot's joint positions
POSE_OR_JOINT = re.compile(r"(?:matrix4d xformOp:transform|double\[\] qpos) = ([^\n]*)")
EDITS = ["cut", "delete", "insert", "insert", "number", "pose", "pose", "custom data"]
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=20,
)


@st.composite
def mutated_stage(draw, text: str) -> bytes:
    """The stage's text with 1-4 edits: cut short, a slice deleted, a token inserted, a number
    made nasty (anywhere, or in a transform or the joint positions), or the randomisation
    custom data replaced by other JSON (or not JSON)."""
    for _ in range(draw(st.integers(1, 4))):
        edit = draw(st.sampled_from(EDITS))
        at = draw(st.integers(min(10, len(text)), len(text)))  # the header: tested above
        if edit == "cut":
            text = text[:at]
        elif edit == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 300)) :]
        elif edit == "insert":
            text = text[:at] + draw(st.sampled_from(TOKENS)) + text[at:]
        elif edit == "number" and (numbers := list(NUMBER.finditer(text))):
            match = numbers[draw(st.integers(0, len(numbers) - 1))]
            text = text[: match.start()] + draw(st.sampled_from(NASTY_NUMBERS)) + text[match.end() :]  # fmt: skip
        elif edit == "pose" and (lines := list(POSE_OR_JOINT.finditer(text))):
            line = lines[draw(st.integers(0, len(lines) - 1))]
            numbers = list(NUMBER.finditer(text, line.start(1), line.end(1)))
            match = numbers[draw(st.integers(0, len(numbers) - 1))]
            text = text[: match.start()] + draw(st.sampled_from(NASTY_NUMBERS)) + text[match.end() :]  # fmt: skip
        elif edit == "custom data":
            value = draw(st.one_of(JSON_VALUES.map(json.dumps), st.text(max_size=30)))
            replacement = "string randomisation = '" + value.replace("'", "\\'") + "'"
            text = re.sub(
                r"string randomisation = '.*'", lambda _, new=replacement: new, text, count=1
            )
    return text.encode("utf-8", "surrogateescape")


_names = itertools.count()


@FUZZ
@given(data=st.data())
def test_reading_a_mutated_stage_gives_its_values_or_one_error_naming_it(exported, tmp_path, data):
    stage_text = (exported / "usd" / f"{KEY}.usda").read_text()
    # a fresh name each time: usd-core keeps layers it has read by name
    path = tmp_path / f"{next(_names)}.usda"
    path.write_bytes(data.draw(mutated_stage(stage_text)))
    randomisation = metadata(grasp_samples()[0])["randomisation"]
    try:
        params, poses, qpos = stored_description(path, randomisation)
    except DatasetError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc).strip(), exc
        return
    assert params == randomisation and len(poses) == len(params["objects"])
    for pose in poses:
        assert np.isfinite(pose["position"]).all() and np.abs(pose["position"]).max() <= MAX_REACH
        assert np.isfinite(pose["quat_wxyz"]).all()
    assert qpos and np.isfinite(qpos).all()
