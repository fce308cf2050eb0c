"""The learned sampler's keys, checked before anything starts: ``--check`` refuses a missing or
wrong model file with one line naming it, and keeps the model's sha256 in the config."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from grasp_model_files import onnx_file, prefers_feature  # tests/grasp_model_files.py

from datagen.config import config_from_dict
from datagen.errors import ConfigError
from datagen.grasp_model.model_file import file_sha256

REPO = Path(__file__).resolve().parents[2]


def check(tmp_path: Path, *options: str, campaign: dict | None = None):
    config = tmp_path / "campaign.yaml"
    data = yaml.safe_load((REPO / "configs/grasp_campaign.yaml").read_text())
    data["campaign"] |= campaign or {}
    config.write_text(yaml.safe_dump(data))
    command = [sys.executable, "-m", "datagen.cli", "campaign", "grasp", str(config)]
    command += ["--out", str(tmp_path / "out"), "--check", *options]
    return subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, check=False)


def refused(done, *needles: str) -> None:
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]


def test_check_passes_with_a_model_given_on_the_command_line(tmp_path):
    prefers_feature(tmp_path / "m.onnx", column=0)
    done = check(tmp_path, "--sampler", "learned", "--model", "m.onnx")
    assert done.returncode == 0, done.stderr
    assert "check passed" in done.stdout


def test_check_refuses_a_learned_sampler_without_a_model(tmp_path):
    refused(check(tmp_path, "--sampler", "learned"), "campaign.model", "--model FILE")


def test_a_model_for_another_sampler_is_refused_not_ignored(tmp_path):
    prefers_feature(tmp_path / "m.onnx", column=0)
    refused(check(tmp_path, "--model", "m.onnx"), "--model", "'antipodal'", "--sampler learned")


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda p: p.write_text("hello"), "not a usable ONNX model"),
        (lambda p: onnx_file(p, lambda c, g: g[:, 0], names=("a", "b")), "expected inputs"),
        (lambda p: None, "cannot read it"),
    ],
)
def test_check_refuses_a_wrong_model_file_in_one_line(tmp_path, make, needle):
    make(tmp_path / "bad.onnx")
    refused(check(tmp_path, "--sampler", "learned", "--model", "bad.onnx"), "bad.onnx", needle)


def test_a_model_named_in_the_config_is_relative_to_it_and_its_digest_is_kept(tmp_path):
    model = prefers_feature(tmp_path / "m.onnx", column=1)
    folder = tmp_path / "configs"
    folder.mkdir()
    config = folder / "c.yaml"
    config.write_text(yaml.safe_dump({"campaign": {"sampler": "learned", "model": "../m.onnx"}}))
    from datagen.config import load_config

    loaded = load_config(config).campaign
    assert Path(loaded.model) == model.resolve()
    assert loaded.model_sha256 == file_sha256(model)
    refused(
        check(
            tmp_path, campaign={"sampler": "learned", "model": str(model), "model_sha256": "0" * 64}
        ),
        "the file changed",
    )


def test_the_wrist_camera_must_be_on_for_a_model_that_sees_through_it(tmp_path):
    model = str(prefers_feature(tmp_path / "m.onnx", column=0))
    data = {"render": {"wrist_camera": False}, "campaign": {"sampler": "learned", "model": model}}
    with pytest.raises(ConfigError, match=r"render\.wrist_camera is false"):
        config_from_dict(data)
    data["campaign"]["model_camera"] = "workspace"
    assert config_from_dict(data).campaign.model_camera == "workspace"


def test_checking_reach_with_the_random_sampler_is_refused_not_ignored(tmp_path):
    done = check(tmp_path, "--sampler", "random", campaign={"check_reach": True})
    refused(done, "campaign.check_reach", "'random'", "antipodal or learned")
    assert check(tmp_path, campaign={"check_reach": True}).returncode == 0  # antipodal


def test_several_grasps_a_scene_need_the_antipodal_sampler_without_the_check(tmp_path):
    refused(
        check(tmp_path, campaign={"grasps_per_scene": 4, "check_reach": True}),
        "campaign.grasps_per_scene",
        "check_reach true",
    )
    with pytest.raises(ConfigError, match=r"grasps_per_scene.*got sampler 'random'"):
        config_from_dict({"campaign": {"sampler": "random", "grasps_per_scene": 4}})
    assert config_from_dict({"campaign": {"grasps_per_scene": 4}}).campaign.grasps_per_scene == 4
