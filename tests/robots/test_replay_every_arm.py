"""``datagen replay`` for every built-in arm: a grasp sample of each arm (rendered here by SAPIEN,
96x72), written as a dataset, exported to USD by the real CLI, and rebuilt from its stage alone
renders the stored images again (the Panda's full build: tests/exports/test_multiview_exports.py)."""

from __future__ import annotations

import json

import pytest
from adversarial.grasp_dataset import cli
from conftest import write_dataset  # tests/conftest.py: shards and a manifest, no MQTT

from datagen.config import config_from_dict
from datagen.registries import FAMILIES, ROBOTS
from datagen.shards import write_json_durably

pytestmark = [pytest.mark.sim]


@pytest.mark.parametrize("name", sorted(set(ROBOTS) - {"panda"}))
def test_replay_from_the_usd_renders_the_stored_images(name, tmp_path):
    from datagen.tools.replay import replay_differences

    raw = {
        "scene": "grasp_tabletop",
        "num_samples": 1,
        "robot": {"name": name},
        "render": {"width": 96, "height": 72},
    }
    config = config_from_dict(raw, source=f"{name} replay test")
    sample = FAMILIES[config.scene].produce_sample(config, 0, 0)
    out = write_dataset(tmp_path / "ds", [sample])
    manifest = json.loads((out / "manifest.json").read_text())
    classes = list(FAMILIES[config.scene].class_names(config))
    write_json_durably(
        out, manifest | {"scene": config.scene, "classes": classes, "config": config.to_dict()}
    )
    code, _, err = cli("export", out, "--to", "usd")
    assert code == 0, err
    assert json.loads(sample.parts["json"])["robot"]["name"] == name
    differences = replay_differences(out, sample.key)
    assert "workspace" in differences
    views = json.loads(sample.parts["json"])["views"]
    for view, (_, _, diff) in differences.items():
        # stored poses and joints are rounded (7 and 6 decimals): now and then an edge crosses
        # a pixel centre, so a pixel or two may differ by more than 2; JPEG compression (a camera
        # effect) spreads such a pixel over its 8x8 block
        jpeg = "jpeg_quality" in views[view].get("camera_effects", {})
        units = _blocks(diff) if jpeg else diff  # pixels, or JPEG blocks
        assert (units != 0).sum() < 1e-3 * diff.size, (name, view)
        assert (units > 2).sum() <= 2e-3 * diff.size, (name, view)


def _blocks(diff):
    """(H/8, W/8) the largest difference in each 8x8 JPEG block of an (H, W) difference."""
    h, w = (n // 8 * 8 for n in diff.shape[:2])
    return diff[:h, :w].reshape(h // 8, 8, w // 8, 8).max(axis=(1, 3))
