"""The robomimic export (docs/export-robomimic.md), written by the real command line from a filmed
grasp campaign and from navigation episodes, read back with h5py and checked against the
dataset's own records (``datagen.load``), then read by robomimic 0.3.0 itself in the readers'
environment (``robomimic_reader.py``: its FileUtils, EnvUtils and SequenceDataset)."""

from __future__ import annotations

import hashlib
import json
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import export_copy  # tests/conftest.py: copy a session dataset, export it

import datagen

pytestmark = pytest.mark.sim
REPO = Path(__file__).resolve().parents[2]
READER = Path(__file__).with_name("robomimic_reader.py")
SEQ = 4  # robomimic_reader.py's sequence length


def _export(source: Path, tmp_path: Path) -> h5py.File:
    root = tmp_path / source.name
    done = export_copy(source, root, "robomimic")
    assert done.returncode == 0, done.stderr[-2000:]
    return h5py.File(root / "robomimic" / "demo.hdf5", "r")


def _valid(key: str) -> bool:  # docs/export-robomimic.md, written here from the page
    return int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "big") % 100 < 10


def _check_common(f: h5py.File, items: dict[str, dict], manifest: dict) -> dict[str, h5py.Group]:
    """The rules every export follows; returns the demos by sample key."""
    data = f["data"]
    demos = {data[name].attrs["datagen_key"]: data[name] for name in data}
    assert sorted(data) == [f"demo_{k}" for k in range(len(data))]
    assert data.attrs["total"] == sum(d.attrs["num_samples"] for d in demos.values())
    env = json.loads(data.attrs["env_args"])
    assert env["env_name"] == f"datagen/{manifest['scene']}" and env["type"] == 2
    assert env["env_version"] == manifest["versions"]["datagen"]
    assert env["env_kwargs"]["config"] == manifest["config"]
    assert env["env_kwargs"]["scene"] == manifest["scene"]
    assert env["env_kwargs"]["seed"] == manifest["seed"]
    train, valid = ([n.decode() for n in f[f"mask/{s}"][:]] for s in ("train", "valid"))
    assert sorted(train + valid) == sorted(data) and not set(train) & set(valid)
    assert valid == [n for n in data if _valid(data[n].attrs["datagen_key"])]
    low, high = data.attrs["action_min"], data.attrs["action_max"]
    stacked = np.concatenate([d["actions"][:] for d in demos.values()])
    assert stacked.min() >= -1 and stacked.max() <= 1
    moving = high > low
    assert np.allclose(stacked.min(0)[moving], -1) and np.allclose(stacked.max(0)[moving], 1)
    for key, demo in demos.items():
        n = demo.attrs["num_samples"]
        item = items[key]
        success = item["meta"].get("attempt", item["meta"].get("episode", {}))
        success = success["outcome"]["success"] if "outcome" in success else success["success"]
        assert demo.attrs["success"] == success
        assert demo["rewards"].shape == (n,) and demo["dones"].shape == (n,)
        assert list(demo["rewards"][:]) == [0.0] * (n - 1) + [float(success)]
        assert list(demo["dones"][:]) == [0] * (n - 1) + [1]
        assert demo["states"].shape[0] == n and demo["actions"].shape[0] == n
        for name, obs in demo["obs"].items():
            assert obs.shape[0] == n, name
            following = np.concatenate([obs[1:], obs[-1:]])
            assert np.array_equal(demo["next_obs"][name][:], following), name
        assert set(demo["next_obs"]) == set(demo["obs"])
    return demos


def _read_by_robomimic(readers_python: Path, f: h5py.File, tmp: Path) -> None:
    """robomimic's own reading of the export: the environment's type by EnvUtils (robomimic's
    GYM_TYPE, not robosuite's), the shapes it trains with, and sequences of SequenceDataset over
    the train mask equal to the file's obs, actions, rewards and dones (padded past a demo's end
    by repeating its last frame)."""
    out = tmp / "robomimic-read"
    out.mkdir()
    command = [str(readers_python), str(READER), f.filename, str(out)]
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp)}
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    read = json.loads(done.stdout.strip().splitlines()[-1])
    data = f["data"]
    assert read["env_meta"] == json.loads(data.attrs["env_args"])
    assert read["env_type"] == 2 and read["gym"] and not read["robosuite"]
    train = sorted((n.decode() for n in f["mask/train"][:]), key=lambda n: int(n[5:]))
    assert read["demos"] == train and read["ac_dim"] == data.attrs["action_min"].shape[0]
    lengths = [int(data[d].attrs["num_samples"]) for d in train]
    assert read["length"] == sum(lengths) and read["use_images"]
    for key, shape in read["shapes"].items():
        stored = data[train[0]]["obs"][key].shape[1:]
        assert shape == ([stored[2], *stored[:2]] if len(stored) == 3 else list(stored)), key
    starts = np.cumsum([0, *lengths])
    for index in read["picks"]:
        k = int(np.searchsorted(starts, index, side="right")) - 1
        demo = data[train[k]]
        rows = np.minimum(np.arange(index - starts[k], index - starts[k] + SEQ), lengths[k] - 1)
        got = np.load(out / f"{index}.npz")
        for name in ("actions", "rewards", "dones"):
            assert np.array_equal(got[name], demo[name][:][rows]), name
        for key in read["shapes"]:
            assert np.array_equal(got[f"obs/{key}"], demo["obs"][key][:][rows]), key


def _unscaled(demo: h5py.Group, data: h5py.Group) -> np.ndarray:
    low, high = data.attrs["action_min"], data.attrs["action_max"]
    return (demo["actions"][:].astype(np.float64) + 1) / 2 * (high - low) + low


def test_robomimic_export_of_a_filmed_campaign(campaign_dataset, readers_python, tmp_path):
    f = _export(campaign_dataset, tmp_path)
    dataset = datagen.load(tmp_path / campaign_dataset.name)
    items = {item["key"]: item for item in dataset}
    manifest = json.loads((tmp_path / campaign_dataset.name / "manifest.json").read_text())
    demos = _check_common(f, items, manifest)
    _read_by_robomimic(readers_python, f, tmp_path)
    assert sorted(demos) == sorted(k for k, it in items.items() if "trajectory" in it)
    # the sensor model's depth is the one part kind no demo holds, and the file says so
    assert json.loads(f["data"].attrs["left_out"]) == ["depth_sensor.png", "wrist.depth_sensor.png"]
    for key, demo in demos.items():
        item, traj = items[key], items[key]["trajectory"]
        rows = np.searchsorted(traj["step"], traj["frame_step"])  # the filmed rows
        qpos, qvel, tcp, target = (traj[n][rows] for n in ("qpos", "qvel", "tcp_pose", "target_pose"))  # fmt: skip
        obs = {name: demo["obs"][name][:] for name in demo["obs"]}
        assert np.allclose(obs["robot0_joint_pos"], qpos[:, :7])
        assert np.allclose(obs["robot0_gripper_qpos"], qpos[:, 7:])
        assert np.allclose(obs["robot0_joint_vel"], qvel[:, :7])
        assert np.allclose(obs["robot0_eef_pos"], tcp[:, :3])
        assert np.allclose(obs["robot0_eef_quat"], tcp[:, [4, 5, 6, 3]])  # x y z w
        assert np.allclose(obs["object"][:, :3], target[:, :3])
        assert np.allclose(obs["object"][:, 7:], target[:, :3] - tcp[:, :3])
        film = traj["frames"]
        assert np.array_equal(obs["agentview_image"], np.stack([fr["rgb"] for fr in film]))
        wrist = np.stack([fr["wrist_rgb"] for fr in film])
        assert np.array_equal(obs["robot0_eye_in_hand_image"], wrist)
        assert np.abs(_unscaled(demo, f["data"]) - traj["action"][rows]).max() < 1e-6
        assert np.allclose(demo["states"][:], np.concatenate([qpos, qvel, target], axis=1))
        assert len(json.loads(demo.attrs["state_names"])) == demo["states"].shape[1]
        for camera, images in (("workspace", item), ("wrist", item["views"]["wrist"])):
            view = demo[f"perception/{camera}"]
            for kind in ("rgb", "depth", "seg", "semantic"):
                assert np.array_equal(view[kind][:], images[kind]), (camera, kind)
            records = item["meta"]["views"][camera]
            visible = [o["instance_id"] for o in [*records["objects"], *records["robot_parts"]] if o["visible"]]  # fmt: skip
            assert [i["instance_id"] for i in json.loads(view.attrs["instances"])] == visible
    f.close()
    doc = (REPO / "docs" / "export-robomimic.md").read_text()  # its snippet, as printed
    marker = "<!-- snippet: tested by tests/exports/test_robomimic.py -->\n```python\n"
    code = doc.split(marker, 1)[1].split("```", 1)[0]
    root = str(tmp_path / campaign_dataset.name)
    exec(compile(code.replace("datasets/grasps", root), "export-robomimic.md", "exec"), {})


def test_robomimic_export_of_navigation_episodes(navigation_dataset, readers_python, tmp_path):
    f = _export(navigation_dataset, tmp_path)
    dataset = datagen.load(tmp_path / navigation_dataset.name)
    items = {item["key"]: item for item in dataset}
    manifest = json.loads((tmp_path / navigation_dataset.name / "manifest.json").read_text())
    demos = _check_common(f, items, manifest)
    _read_by_robomimic(readers_python, f, tmp_path)
    assert sorted(demos) == sorted(items)
    assert json.loads(f["data"].attrs["left_out"]) == ["map.png", "occupancy.png", "poses.head.txt"]
    fps = manifest["config"]["navigation"]["frame_rate_hz"]
    for key, demo in demos.items():
        frames = [fr for fr in items[key]["frames"] if abs(fr["meta"]["time_s"] * fps - round(fr["meta"]["time_s"] * fps)) < 1e-6]  # fmt: skip
        assert demo.attrs["num_samples"] == len(frames) and demo.attrs["fps"] == fps
        records = [fr["meta"] for fr in frames]
        pose = np.array([r["pose"] for r in records])
        obs = demo["obs"]
        assert np.allclose(obs["pose"][:], pose) and np.allclose(demo["states"][:], pose)
        assert np.allclose(obs["goal_in_robot"][:], [r["goal_in_robot"] for r in records])
        assert np.array_equal(obs["head_image"][:], np.stack([fr["rgb"] for fr in frames]))
        far = demo.attrs["depth_far_m"]
        assert far == items[key]["meta"]["camera"]["far"]
        depth_mm = obs["head_depth"][:, :, :, 0] * far * 1000
        assert np.abs(depth_mm - np.stack([fr["depth"] for fr in frames])).max() < 0.01
        assert obs["head_depth"][:].min() >= 0 and obs["head_depth"][:].max() <= 1
        actions = np.array([np.ravel(r["action"]) for r in records])  # to the next frame
        assert np.abs(_unscaled(demo, f["data"]) - actions).max() < 1e-6
        for kind in ("seg", "semantic"):
            stack = np.stack([fr[kind] for fr in frames])
            assert np.array_equal(demo[f"perception/{kind}"][:], stack)
        things = json.loads(demo["perception"].attrs["instances"])
        assert things == [r["things"] for r in records]


def test_robomimic_refuses_single_frames(frames_dataset, tmp_path):
    root = tmp_path / "frames"
    done = export_copy(frames_dataset, root, "robomimic")
    assert done.returncode != 0 and "cannot export 'robomimic'" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and not (root / "robomimic").exists()
