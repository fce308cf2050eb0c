"""A sample is a function of (seed, index) alone, whatever its worker produced before it.

Workers keep per-process caches (the parsed robot builders, SAPIEN's meshes and render
resources) and build a fresh PhysX scene per sample. Here index i is produced in a fresh process
and, in another process, after a different history of other indices; every part's bytes must
match. Each process calls the scene family's ``produce_sample`` in a loop, as a worker does.
"""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from conftest import python_lines  # tests/conftest.py

REPO = Path(__file__).resolve().parents[2]

pytestmark = [pytest.mark.sim, pytest.mark.slow]

PRODUCE = """
import hashlib, json, sys
from datagen.config import load_config
from datagen.config.sections import RenderConfig
from datagen.registries import FAMILIES

config_file, scene, indices = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
config = load_config(config_file)
config = config.replace(scene=scene, render=RenderConfig(width=96, height=72))
digests = {}
for index in indices:
    sample = FAMILIES[scene].produce_sample(config, config.seed, index)
    digests[index] = {name: hashlib.sha256(data).hexdigest() for name, data in sample.parts.items()}
print(json.dumps(digests))
"""


def produce_in_new_process(config: str, scene: str, indices: list[int]) -> dict[int, dict]:
    """{index: {part name: sha256}} of ``indices`` produced one after another in one process."""
    lines = python_lines(PRODUCE, REPO / config, scene, json.dumps(indices))
    return {int(k): v for k, v in json.loads(lines[-1]).items()}


@pytest.mark.parametrize(
    ("config", "scene", "history", "index"),
    [
        ("configs/grasp_tabletop.yaml", "grasp_tabletop", [3, 7, 1], 2),
        ("configs/grasp_campaign.yaml", "grasp_attempts", [1], 0),
        ("configs/nav_maze.yaml", "navigation", [1], 0),
        ("configs/campaign_iiwa14.yaml", "grasp_attempts", [1], 0),
        ("configs/campaign_xarm7.yaml", "grasp_attempts", [2], 0),
        ("configs/campaign_so100.yaml", "grasp_attempts", [1], 0),
        ("configs/campaign_koch.yaml", "grasp_attempts", [2], 0),
    ],
)
def test_sample_bytes_do_not_depend_on_the_worker_history(config, scene, history, index):
    with ThreadPoolExecutor(2) as pool:  # two processes side by side: one per core
        fresh_run = pool.submit(produce_in_new_process, config, scene, [index])
        reused_run = pool.submit(produce_in_new_process, config, scene, [*history, index])
        fresh, reused = fresh_run.result()[index], reused_run.result()
    assert len({json.dumps(d, sort_keys=True) for d in reused.values()}) == len(reused)
    assert "json" in fresh and any(name.endswith("rgb.png") for name in fresh)
    changed = sorted(name for name in fresh if fresh[name] != reused[index].get(name))
    assert reused[index].keys() == fresh.keys()
    assert not changed, f"index {index} after indices {history} differs in {changed}"
