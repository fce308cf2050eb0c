"""A grasp-attempt campaign end to end on the real stack: workers execute grasps in SAPIEN,
samples go through Mosquitto to the writer, statistics land in the manifest."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from datagen.config import BuildConfig
from datagen.config.sections import CampaignConfig, OutputConfig, RenderConfig
from datagen.dataset.loader import load, verify
from datagen.families.grasp_attempts.grasps import FAILURE_MODES
from datagen.pipeline.run import run_build

pytestmark = [pytest.mark.sim, pytest.mark.mqtt, pytest.mark.slow]  # real builds

REPO = Path(__file__).resolve().parents[2]
ATTEMPTS = 6
CONFIG = BuildConfig(
    scene="grasp_attempts",
    num_samples=ATTEMPTS,
    seed=5,
    render=RenderConfig(width=160, height=120),
    campaign=CampaignConfig(hold_time=0.5),
    output=OutputConfig(formats=("webdataset", "hdf5")),
)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign")
    run_build(CONFIG, out, workers=2)
    return out


def test_exact_count_and_an_attempt_record_per_sample(campaign):
    manifest = verify(campaign)
    dataset = load(campaign)
    assert manifest["samples"] == len(dataset) == ATTEMPTS
    for i in range(ATTEMPTS):
        item = dataset[i]
        attempt = item["meta"]["attempt"]
        assert attempt["attempt_id"] == item["key"] and attempt["scene_seed"] == CONFIG.seed
        outcome = attempt["outcome"]
        assert outcome["success"] or outcome["failure_mode"] in FAILURE_MODES
        if attempt["grasp"] is not None:
            grasp = attempt["grasp"]
            assert len(grasp["pose_world"]) == 4 and len(grasp["pose_camera"]["matrix"]) == 4
            assert 0 < grasp["width"] <= 0.08 + 1e-6
        assert {"post.rgb.png", "post.depth.png", "post.seg.png"} <= set(dataset.raw(i))


def test_attempts_export_to_hdf5(campaign):
    dataset = load(campaign)
    with h5py.File(campaign / "episodes.h5", "r") as f:
        assert f.attrs["scene"] == "grasp_attempts"
        for i, key in enumerate(f["index/keys"][:].astype(str)):
            attempt, group = dataset.metadata(i)["attempt"], f[f"samples/{key}"]
            assert key == dataset.keys[i]
            assert f["index/success"][i] == group.attrs["success"] == attempt["outcome"]["success"]
            assert group.attrs["failure_mode"] == (attempt["outcome"]["failure_mode"] or "")
            if attempt["grasp"] is not None:
                np.testing.assert_allclose(group["grasp/pose_world"][()], attempt["grasp"]["pose_world"])  # fmt: skip
            assert group["post/rgb"].shape == group["rgb"].shape


def test_campaign_statistics_in_the_manifest_match_the_records(campaign):
    manifest = json.loads((campaign / "manifest.json").read_text())
    stats = manifest["campaign"]
    attempts = [load(campaign).metadata(i)["attempt"] for i in range(ATTEMPTS)]
    successes = sum(a["outcome"]["success"] for a in attempts)
    assert stats["attempts"] == ATTEMPTS and stats["successes"] == successes
    assert sum(stats["failure_modes"].values()) == ATTEMPTS - successes
    assert stats["per_sampler"]["antipodal"]["attempts"] == ATTEMPTS
    assert stats["attempts_per_s"] > 0


def test_inspect_writes_pictures_and_a_summary(campaign, tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "datagen.cli", "inspect", str(campaign)],
        capture_output=True, text=True, cwd=REPO, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert f"samples{' ' * 4}" in result.stdout and "success_rate" in result.stdout  # the table
    summary = json.loads((campaign / "inspect" / "summary.json").read_text())
    assert summary["samples"] == ATTEMPTS and summary["campaign"]["attempts"] == ATTEMPTS
    for name in ("overview.png", "distributions.png", "randomisation.png"):
        assert (campaign / "inspect" / name).stat().st_size > 10_000
    # the default appearance randomisation shows in the summary: textured surfaces and flat ones
    assert set(summary["surface_textures"]) - {"flat", "picture"}, summary["surface_textures"]


def test_campaign_command_line(tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(CONFIG.to_dict() | {"scene": "grasp_tabletop"}))
    result = subprocess.run(
        [sys.executable, "-m", "datagen.cli", "campaign", "grasp", str(config), "--attempts", "3",
         "--sampler", "random", "--out", str(tmp_path / "out"), "--workers", "1"],
        capture_output=True, text=True, cwd=REPO, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "3 grasp attempts" in result.stdout and "random" in result.stdout
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["config"]["scene"] == "grasp_attempts"
    assert manifest["campaign"]["per_sampler"]["random"]["attempts"] == 3
