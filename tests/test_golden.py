"""Samples of fixed seed are byte-for-byte those of commit c1ba73d, before the scene families
became plug-ins (tests/data/golden_parts.json: sha256 of every part). The digests were recorded
with Mesa's lavapipe (llvmpipe) on x86-64, as on CI; another renderer draws other pixels, so the
test runs only there."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
import sapien

from datagen.config import load_config
from datagen.registries import FAMILIES

REPO = Path(__file__).resolve().parents[1]
GOLDEN = json.loads((REPO / "tests" / "data" / "golden_parts.json").read_text())
SCENE = {"configs/grasp_campaign.yaml": "grasp_attempts"}

pytestmark = [pytest.mark.sim, pytest.mark.slow]


@pytest.fixture(scope="module", autouse=True)
def lavapipe():
    device = sapien.render.get_device_summary()
    if "llvmpipe" not in device:
        pytest.skip(f"golden digests are lavapipe's; this machine renders with: {device[:80]}")


@pytest.mark.parametrize(
    ("config", "key"), [(c, k) for c, keys in sorted(GOLDEN.items()) for k in sorted(keys)]
)
def test_sample_bytes_are_unchanged(config, key):
    cfg = load_config(REPO / config)
    cfg = cfg.replace(scene=SCENE.get(config, cfg.scene))
    sample = FAMILIES[cfg.scene].produce_sample(cfg, cfg.seed, int(key))
    digests = {name: hashlib.sha256(data).hexdigest() for name, data in sample.parts.items()}
    assert digests == GOLDEN[config][key]
