"""A dataset's ``croissant.json`` read the consumer's way: mlcroissant 1.1.1, in the readers'
environment, iterates every record set (``tests/exports/croissant_records.py``) of a real build of
each kind (grasp frames, a filmed grasp campaign, navigation and aerial episodes); each yields one
record per tar member of its kind, and the records' keys, names, JSON and decoded pixels equal
what datagen's own loader reads from the shards."""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
from collections import Counter
from pathlib import Path

import cv2
import numpy as np
import pytest

import datagen
from datagen.dataset.parts import decode_parts

pytestmark = pytest.mark.sim
READER = Path(__file__).with_name("croissant_records.py")
FIRST = 3  # records of each set whose values are compared
_FRAME = re.compile(r"^(frame|f)\d+$")


def _records(readers_python: Path, dataset: Path, cache: Path) -> dict:
    cache.mkdir()
    command = [str(readers_python), str(READER), str(dataset / "croissant.json"), str(FIRST)]
    env = {"CROISSANT_CACHE": str(cache), "PATH": "/usr/bin:/bin", "HOME": str(cache)}
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _record_set(part: str) -> str:
    """The record set of a part name, as the card names it: f0003.d0.rgb.png -> f_k_d0_rgb_png."""
    kind = ".".join(f"{p[1]}_k" if (p := _FRAME.match(x)) else x for x in part.split("."))
    return re.sub(r"[^A-Za-z0-9_-]", "_", kind)


def _pixels(part: str, data: bytes) -> dict:
    """The loader's decoding of an image part, described as the reader describes PIL's."""
    kind = part.split(".")[-2]
    if kind == "occupancy":  # the loader returns it as bool (occupied); the PNG holds 0 or 255
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        assert np.array_equal(image > 0, decode_parts({"occupancy.png": data})["occupancy"])
    else:
        field = "rgb" if kind in ("map", "side") else kind
        image = decode_parts({f"{field}.png": data})[field]
    digest = hashlib.sha256(np.ascontiguousarray(image).tobytes()).hexdigest()
    return {"shape": list(image.shape), "dtype": str(image.dtype), "sha256": digest}


def _check_values(dataset, read: dict) -> None:
    index = {key: i for i, key in enumerate(dataset.keys)}
    for record_set, records in read["records"].items():
        assert records, record_set
        for record in records:
            key, name = record["key"], record["name"]
            part = name.removeprefix(f"{key}.")
            assert name.startswith(f"{key}.") and part in dataset.part_names(index[key])
            assert _record_set(part) == record_set
            data = dataset.raw(index[key], {part})[part]
            if part == "json":
                assert json.loads(record["content"]) == dataset.metadata(index[key])
            elif part.endswith(".txt"):
                assert record["content"] == data.decode()
            elif part.endswith(".png") and not part.endswith(".flow.png"):
                assert record["content"] == _pixels(part, data), name
            else:  # npz, flow: listed, their content not decoded
                assert "content" not in record, name


@pytest.mark.parametrize(
    "name", ["frames_dataset", "campaign_dataset", "navigation_dataset", "aerial_dataset"]
)
def test_mlcroissant_yields_every_record_of_every_dataset_kind(
    name, request, readers_python, tmp_path
):
    root = request.getfixturevalue(name)
    read = _records(readers_python, root, tmp_path / "cache")
    dataset = datagen.load(root)
    members = Counter(
        _record_set(part) for i in range(len(dataset)) for part in dataset.part_names(i)
    )
    assert read["counts"] == dict(members) and all(members.values())
    _check_values(dataset, read)
    counts = read["counts"]
    items = list(dataset)
    if name == "frames_dataset":
        assert counts["json"] == counts["rgb_png"] == counts["view1_rgb_png"] == len(items)
    elif name == "campaign_dataset":
        filmed = sum(len(item["trajectory"]["frames"]) for item in items if "trajectory" in item)
        assert counts["frame_k_rgb_png"] == counts["frame_k_wrist_rgb_png"] == filmed > 0
        assert counts["trajectory_npz"] == sum("trajectory" in item for item in items) > 0
    elif name == "navigation_dataset":
        assert counts["f_k_rgb_png"] == sum(len(item["frames"]) for item in items) > 0
    else:
        frames = [f["cameras"]["d0"] for item in items for f in item["frames"]]
        assert counts["f_k_d0_rgb_png"] == len(frames) > 0
        assert counts["f_k_d0_flow_png"] == sum("flow" in f for f in frames) > 0
