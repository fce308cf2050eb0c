"""Property-based fuzz of every writer of dataset-sourced text (issue 38): a real grasp dataset
whose manifest (build id, class names, versions, date) and sample metadata (a class, the robot's
description, a number anywhere in a camera, a pose or a box) are drawn by Hypothesis, exported
by the real command line to YOLO, COCO, BOP and HDF5 with the dataset card and Croissant files.

Whatever is drawn: the command exits 0, or 2 with one line and no traceback; every YAML file
parses to exactly the keys datagen writes (``data.yaml``, the cards' front matter), every JSON
file parses strictly (no ``NaN`` or ``Infinity``), the cards' Markdown holds no HTML and no link
but datagen's own, and nothing is written outside the dataset's folder."""

from __future__ import annotations

import contextlib
import json
import re
import shutil
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from adversarial.forged_datasets import snapshot
from adversarial.hostile_exports import (
    DATA_YAML,
    FRONT_MATTER,
    cli,
    forged,
    front_matter,
    grasp_source,
    link_targets,
    rendered,
)

pytestmark = [pytest.mark.adversarial, pytest.mark.sim, pytest.mark.slow]
FUZZ = settings(
    deadline=None,
    derandomize=True,
    database=None,
    max_examples=100,  # about 20 s on the 2-core machine
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
FORMATS = "yolo,coco,bop,hdf5"
OWN_LINKS = {"yolo/README.md", "coco/README.md", "bop/README.md", "../README.md"}
# text a manifest may hold (no control character or line break), and any text at all
line_text = st.text(st.characters(blacklist_categories=("Cc", "Cs", "Zl", "Zp")), max_size=30)
any_text = st.text(max_size=30)
markup = st.sampled_from(
    ["<script>x</script>", "](javascript:x)", "| a | b |", "```", "\n---\n", "{%", "\\"]
)
texts = st.one_of(
    line_text, any_text, markup, st.lists(markup | line_text, max_size=4).map("".join)
)
numbers = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False),
    st.integers(-(2**70), 2**70),
    st.sampled_from([1e308, -1e308, 3.5e38, 1e30, 0, -1, 2e6]),
)
NUMBER_PATHS = [  # (view or object, keys) of numbers an export writes or computes from
    ("camera", ["intrinsics", 0, 2]),
    ("camera", ["render_intrinsics", 1, 1]),
    ("camera", ["extrinsics_world_to_camera", 2, 3]),
    ("camera", ["distortion", 0]),
    ("seen", ["bbox_xyxy", 2]),
    ("seen", ["visible_fraction"]),
    ("seen", ["pose_camera", "matrix", 1, 3]),
    ("object", ["pose_world", "matrix", 0, 3]),
    ("object", ["mass"]),
    ("object", ["shape", "parts", 0, "extents", 1]),
]


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    return grasp_source(tmp_path_factory)


@contextlib.contextmanager
def workspace():
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / "outside").mkdir()
        (work / "outside" / "x.txt").write_text("precious")
        yield work


def _set(doc, keys: list, value) -> None:
    for key in keys[:-1]:
        doc = doc[key]
    doc[keys[-1]] = value


def _sample_change(draw):
    name, description = draw(texts), draw(texts)
    where, keys = draw(st.sampled_from(NUMBER_PATHS))
    number = draw(numbers)

    def change(meta):
        view = meta["views"]["workspace"]
        meta["classes"][meta["classes"].index("box")] = name
        for seen in view["objects"]:
            seen["class"] = name if seen["class"] == "box" else seen["class"]
        for obj in meta["objects"]:
            obj["class"] = name if obj["class"] == "box" else obj["class"]
        meta["robot"]["description"] = description
        target = {
            "camera": view["camera"],
            "seen": view["objects"][0],
            "object": meta["objects"][0],
        }
        _set(target[where], keys, number)

    return change


def _manifest_change(draw):
    build_id = draw(st.from_regex(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}", fullmatch=True))
    fields = {"classes": draw(texts), "version": draw(texts), "date": draw(texts)}

    def change(manifest):
        manifest["build_id"] = build_id
        manifest["classes"].append(fields["classes"])
        manifest["versions"] |= {"datagen": fields["version"], fields["version"]: fields["date"]}
        manifest["created_utc"] = fields["date"]

    return change


def check_outputs(root: Path) -> None:
    for path in root.rglob("*"):
        if path.suffix == ".json":
            json.loads(path.read_text(), parse_constant=_refuse)
        elif path.name == "data.yaml":
            data = yaml.safe_load(path.read_text())
            assert set(data) == DATA_YAML and all(
                isinstance(n, str) for n in data["names"].values()
            )
        elif path.name == "README.md":
            header, body = front_matter(path.read_text())
            assert set(header) <= FRONT_MATTER, (path, header)
            tokens, _ = rendered(body)
            assert not [t.content for t in tokens if t.type.startswith("html")], path
            links = link_targets(tokens)
            assert links <= OWN_LINKS, (path, links)


@FUZZ
@given(data=st.data())
def test_every_text_file_an_export_writes_is_well_formed(source, data):
    with workspace() as work:
        root = forged(
            source,
            work / "ds",
            meta=_sample_change(data.draw),
            manifest=_manifest_change(data.draw),
        )
        outside = {k: v for k, v in snapshot(work).items() if not k.startswith(str(root))}

        code, _, err = cli("export", root, "--to", FORMATS)
        event(f"exit {code}")  # --hypothesis-show-statistics: how many examples wrote every file
        assert code in (0, 2) and "Traceback" not in err, err
        lines = err.strip().splitlines()  # progress lines of the formats done, then the refusal
        assert all(re.match(r"datagen: \d+/\d+ exported to ", line) for line in lines[:-1]), err
        check_outputs(root)
        assert {k: v for k, v in snapshot(work).items() if not k.startswith(str(root))} == outside
        shutil.rmtree(root)


def _refuse(name: str):
    raise ValueError(f"{name} in JSON")
