"""A worker's warm-up (datagen/pipeline/warm_up.py) takes what only a process's first sample
paid out of that sample, and changes none of its bytes: each case runs in a fresh interpreter,
as a worker starts, for the ``example_blocks`` plug-in family (tests/plugins: SAPIEN's own
camera, whose first frame computes SAPIEN's BRDF table) and a built-in family."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.sim
REPO = Path(__file__).resolve().parents[2]
FIRST_SAMPLE = """
import hashlib, json, sys, time
from datagen.config import config_from_dict
from datagen.sensing.render import keep_renderer_alive
from datagen.pipeline.warm_up import warm_up
from datagen.registries import FAMILIES
config = config_from_dict({"scene": sys.argv[1], "seed": 7, "render": {"width": 48, "height": 32}})
warm_up(config) if sys.argv[2] == "warm" else keep_renderer_alive()
start = time.perf_counter()
sample = FAMILIES[config.scene].produce_sample(config, config.seed, 0)
seconds = time.perf_counter() - start
digests = {name: hashlib.sha256(data).hexdigest() for name, data in sample.parts.items()}
print(json.dumps({"seconds": seconds, "digests": digests}))
"""


def first_sample(scene: str, start: str) -> dict:
    plugins = os.pathsep.join(filter(None, [str(REPO / "tests" / "plugins"), os.environ.get("PYTHONPATH")]))  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-c", FIRST_SAMPLE, scene, start], cwd=REPO, capture_output=True,
        text=True, timeout=300, env=os.environ | {"PYTHONPATH": plugins},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("scene", ["example_blocks", "grasp_tabletop"])
def test_the_warm_up_changes_no_byte_of_the_first_sample(scene):
    assert first_sample(scene, "warm")["digests"] == first_sample(scene, "cold")["digests"]


def test_a_plugin_familys_first_sample_no_longer_pays_sapiens_first_frame():
    """Without the warm-up it took 4.7-9 s on lavapipe (the BRDF table); with it, 0.1 s."""
    assert first_sample("example_blocks", "warm")["seconds"] < 2.0
