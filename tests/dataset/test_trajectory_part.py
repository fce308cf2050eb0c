"""The ``trajectory.npz`` part without a simulator: the recorder's rates and rows, the loader's
checks of the archive and of the frames, and the config keys' limits."""

from __future__ import annotations

import io

import cv2
import numpy as np
import pytest

from datagen.config import ConfigError, config_from_dict
from datagen.dataset.loader import DatasetError
from datagen.dataset.parts import decode_parts
from datagen.dataset.trajectory import decode_trajectory
from datagen.families.grasp_attempts.recording import Recorder, StepState, steps_per_sample

JOINTS = ("j1", "j2", "f1", "f2")
ARM = ("j1", "j2")


def _state(step: int) -> StepState:
    return StepState(
        qpos=np.full(4, 0.01 * step),
        qvel=np.zeros(4),
        gripper_opening=0.04,
        tcp_pose=np.array([0.1, 0, 0.9, 1, 0, 0, 0]),
        target_pose=np.array([0.1, 0, 0.8, 1, 0, 0, 0]),
        contact=(1.0, 0.0, 0.002),
    )


def _recorded(frames: list[int] | None = None) -> bytes:
    """25 steps at 5 ms: rows every 10 steps (20 Hz), frames every 20 (10 Hz), a last row."""
    recorder = Recorder(0.005, 20.0, JOINTS, ARM, 10.0, None if frames is None else frames.append)
    for step in range(25):
        if step in (0, 12):
            recorder.begin_phase("open" if step == 0 else "close", step)
        if recorder.command(step, np.array([0.1, 0.2, 0.0, 0.0, 0.03 + step])):
            recorder.state(step, _state(step))
    recorder.finish(25, _state(25))
    return recorder.encode()


def test_rows_frames_and_names():
    frames: list[int] = []
    trajectory = decode_trajectory(_recorded(frames))
    assert trajectory["step"].tolist() == [0, 10, 20, 25] and frames == [0, 1]
    np.testing.assert_allclose(trajectory["time"], [0, 0.05, 0.1, 0.125])
    assert trajectory["phase"].tolist() == [0, 0, 3, 3]
    assert trajectory["phase_start_step"].tolist() == [0, -1, -1, 12, -1, -1]
    assert trajectory["qpos"].shape == (4, 4) and trajectory["step_action"].shape == (25, 5)
    np.testing.assert_allclose(trajectory["action"][1], [0.1, 0.2, 10.03], rtol=1e-6)
    np.testing.assert_allclose(trajectory["action"][-1], [0.1, 0.2, 24.03], rtol=1e-6)  # last
    assert trajectory["frame_step"].tolist() == [0, 20]
    names = trajectory["names"]
    assert names["joint_names"] == list(JOINTS) and names["action_names"] == [
        "j1",
        "j2",
        "finger_target",
    ]
    assert names["record_hz"] == 20.0 and names["frame_hz"] == 10.0


def test_rates_round_to_whole_steps_and_stay_below_the_physics_rate():
    assert steps_per_sample(20.0, 0.005, "k") == 10 and steps_per_sample(30.0, 0.005, "k") == 7
    assert steps_per_sample(200.0, 0.005, "k") == 1
    with pytest.raises(
        ValueError, match=r"campaign\.record_hz: 300\.0 Hz is above the physics rate"
    ):
        steps_per_sample(300.0, 0.005, "campaign.record_hz")


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def _arrays() -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(_recorded()), allow_pickle=False) as npz:
        return {key: npz[key] for key in npz.files}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda a: a.update(qpos=a["qpos"][:, :3]), "array 'qpos' is float32 \\(4, 3\\)"),
        (lambda a: a.update(time=a["time"].astype(np.float64)), "array 'time' is float64"),
        (lambda a: a.pop("contact"), "missing arrays \\['contact'\\]"),
        (lambda a: a.update(extra=np.zeros(2)), "unknown \\['extra'\\]"),
        (lambda a: a["tcp_pose"].__setitem__((0, 0), np.nan), "'tcp_pose' holds non-finite"),
        (lambda a: a.update(names=np.frombuffer(b"[1]", np.uint8)), "not datagen.trajectory/1"),
        (lambda a: a.update(qvel=np.array([{"a": 1}], dtype=object)), "not a readable .npz"),
    ],
)
def test_a_bad_archive_is_refused_naming_what_is_wrong(change, message):
    arrays = _arrays()
    change(arrays)
    with pytest.raises(DatasetError, match=message):
        decode_trajectory(_npz(**arrays))


def test_not_an_archive_is_refused():
    with pytest.raises(DatasetError, match=r"not a readable \.npz"):
        decode_trajectory(b"PK\x03\x04 not really")


def _png() -> bytes:
    return cv2.imencode(".png", np.zeros((6, 8, 3), np.uint8))[1].tobytes()


def test_loader_attaches_the_frames_in_time_order():
    parts = {"trajectory.npz": _recorded(), "frame1.rgb.png": _png(), "frame0.rgb.png": _png()}
    parts |= {"frame0.wrist.rgb.png": _png(), "frame1.wrist.rgb.png": _png()}
    item = decode_parts(parts)
    frames = item["trajectory"]["frames"]
    assert [f["time"] for f in frames] == pytest.approx([0.0, 0.1])
    assert frames[1]["rgb"].shape == frames[1]["wrist_rgb"].shape == (6, 8, 3)
    assert "views" not in item  # frames are no camera of the sample


@pytest.mark.parametrize(
    "parts", [{"frame0.rgb.png"}, {"trajectory.npz", "frame0.rgb.png", "frame2.rgb.png"}]
)
def test_frames_must_match_the_frame_times(parts):
    data = {"trajectory.npz": _recorded()} | {name: _png() for name in parts if "frame" in name}
    with pytest.raises(DatasetError, match="do not match"):
        decode_parts({name: data[name] for name in parts})


@pytest.mark.parametrize(
    ("campaign", "message"),
    [
        ({"record_hz": 400}, "campaign.record_hz: expected at most the physics rate 200 Hz"),
        ({"record_hz": 0, "frame_hz": 5}, "campaign.frame_hz: frames need campaign.record_hz"),
    ],
)
def test_config_limits(campaign, message):
    with pytest.raises(ConfigError, match=message):
        config_from_dict({"scene": "grasp_attempts", "campaign": campaign}, "c.yaml")
