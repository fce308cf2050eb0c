"""Real grasp samples (``grasp_tabletop`` rendered in this process by SAPIEN on lavapipe, 64x48
pixels, about 5 s once per test session) and datasets of them written as a build writes them:
shards and a manifest with the scene, classes and config. For attacks that edit a real sample's
metadata or its USD description, so that the bad values reach the real drawing and replay code.
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from datagen.cli import main
from datagen.config import config_from_dict
from datagen.registries import FAMILIES
from datagen.sample import Sample
from datagen.shards import write_json_durably

CONFIG = {
    "scene": "grasp_tabletop",
    "num_samples": 2,
    "render": {"width": 64, "height": 48},
    "objects": {"count": [2, 3]},
}


@functools.cache
def grasp_samples() -> tuple[Sample, ...]:
    config = config_from_dict(CONFIG, source="grasp_dataset.CONFIG")
    family = FAMILIES[config.scene]
    return tuple(family.produce_sample(config, 0, i) for i in range(config.num_samples))


def metadata(sample: Sample) -> dict[str, Any]:
    return json.loads(sample.parts["json"])


def with_json(sample: Sample, text: str | bytes) -> Sample:
    """``sample`` with its metadata part replaced by ``text`` as it is (any bytes a file holds)."""
    data = text.encode() if isinstance(text, str) else text
    return Sample(sample.index, sample.parts | {"json": data})


def write_grasp_dataset(out: Path, samples: list[Sample], make_dataset: Callable) -> Path:
    """A finalized dataset of ``samples`` whose manifest names the scene and its config."""
    make_dataset(out, samples, shard_size=2)
    manifest = json.loads((out / "manifest.json").read_text())
    config = config_from_dict(CONFIG, source="grasp_dataset.CONFIG")
    extra = {
        "scene": config.scene,
        "classes": list(FAMILIES[config.scene].class_names(config)),
        "config": config.to_dict(),
    }
    write_json_durably(out, manifest | extra)
    return out


def cli(*argv: object) -> tuple[int, str, str]:
    """``datagen ARGV`` in this process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse's errors
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def usd_dataset(out: Path, make_dataset: Callable) -> Path:
    """The grasp samples as a dataset with their USD descriptions (``usd/KEY.usda``)."""
    write_grasp_dataset(out, list(grasp_samples()), make_dataset)
    code, _, err = cli("export", out, "--to", "usd")
    assert code == 0, err
    return out
