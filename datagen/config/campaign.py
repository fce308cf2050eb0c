"""The learned grasp sampler's keys, checked before anything starts: its model file is read and
held to the contract of ``datagen.grasp_model.model_file``, and its sha256 is kept in the config
(so the manifest, the build state and a resumed campaign all name the model that scored)."""

from __future__ import annotations

import dataclasses
from typing import Any

from datagen.errors import ConfigError
from datagen.grasp_model.model_file import ModelFileError, load_model

MODEL_CAMERAS = ("wrist", "workspace")
REACH_CHECKED = ("antipodal", "learned")  # samplers with candidates to choose among


def check_campaign_model(config: Any, source: str) -> Any:
    """``config`` (a BuildConfig) with ``campaign.model_sha256`` filled in when the sampler is
    ``learned``; ConfigError naming the key otherwise, and for ``check_reach`` or
    ``grasps_per_scene`` with a sampler they do not apply to. Other samplers leave it as it is."""
    campaign = config.campaign
    if campaign.check_reach and campaign.sampler not in REACH_CHECKED:
        raise ConfigError(
            f"{source}: campaign.check_reach: the {campaign.sampler!r} sampler draws one pose "
            f"and has none to choose among: use it with {' or '.join(REACH_CHECKED)}"
        )
    if campaign.grasps_per_scene > 1 and (campaign.sampler != "antipodal" or campaign.check_reach):
        raise ConfigError(
            f"{source}: campaign.grasps_per_scene: {campaign.grasps_per_scene} attempts a scene "
            "execute the antipodal sampler's first candidates in turn; it needs sampler "
            f"'antipodal' without check_reach (got sampler {campaign.sampler!r}, check_reach "
            f"{str(campaign.check_reach).lower()})"
        )
    if campaign.sampler != "learned":
        return config
    if not campaign.model:
        raise ConfigError(
            f"{source}: campaign.model: the learned sampler needs a model file (ONNX, "
            "docs/campaigns.md 'Learning to grasp'): set it, or pass --model FILE"
        )
    if campaign.model_camera not in MODEL_CAMERAS:
        raise ConfigError(
            f"{source}: campaign.model_camera: expected one of {list(MODEL_CAMERAS)}, "
            f"got {campaign.model_camera!r}"
        )
    if campaign.model_camera == "wrist" and not config.render.wrist_camera:
        raise ConfigError(
            f"{source}: campaign.model_camera: 'wrist', but render.wrist_camera is false: turn "
            "the wrist camera on or give the model the 'workspace' camera"
        )
    try:
        model = load_model(campaign.model, campaign.model_sha256)
    except ModelFileError as exc:
        raise ConfigError(f"{source}: campaign.model: {exc}") from None
    campaign = dataclasses.replace(campaign, model_sha256=model.sha256)
    return dataclasses.replace(config, campaign=campaign)
