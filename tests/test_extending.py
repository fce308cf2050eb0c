"""docs/extending.md, done for real: a scene family (with its randomiser), a grasp sampler and an
export format added as plug-ins from tests/plugins (one module each, registered by entry points
the way an installed package registers them), built and exported through the real pipeline:
workers, Mosquitto, writer. Also the sample-error policy, with faults injected into chosen
indices of the example family."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from datagen.dataset.loader import load

REPO = Path(__file__).resolve().parents[1]
PLUGINS = REPO / "tests" / "plugins"
CONFIG = """\
scene: example_blocks
num_samples: 5
seed: 7
render: {width: 128, height: 96}
"""


def datagen(*args: str, faults: str = "", **env: str) -> subprocess.CompletedProcess:
    path = os.pathsep.join(filter(None, [str(PLUGINS), os.environ.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=600,
        env=os.environ | {"PYTHONPATH": path, "EXAMPLE_BLOCKS_FAIL": faults} | env,
    )


def config_file(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "blocks.yaml"
    path.write_text(CONFIG + extra)
    return path


def samples(out: Path) -> dict[str, dict[str, bytes]]:
    dataset = load(out)
    return {key: dataset.raw(i) for i, key in enumerate(dataset.keys)}


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_plugin_family_builds_and_every_generic_tool_reads_it(tmp_path):
    out = tmp_path / "blocks"
    built = datagen("build", str(config_file(tmp_path)), "--out", str(out), "--workers", "2")
    assert built.returncode == 0, built.stderr
    dataset = load(out)
    assert len(dataset) == 5 and dataset.manifest["classes"] == ["background", "floor", "block"]
    meta = dataset.metadata(0)
    visible = [o for o in meta["views"]["workspace"]["objects"] if o["visible"]]
    assert visible, "the camera sees at least one block"
    assert (out / "preview.png").is_file()

    exported = datagen("export", str(out), "--to", "labels_csv,coco,hdf5,pointcloud")
    assert exported.returncode == 0, exported.stderr
    rows = list(csv.DictReader((out / "labels.csv").read_text().splitlines()))
    expected = sum(
        o["visible"] for i in range(5) for o in dataset.metadata(i)["views"]["workspace"]["objects"]
    )
    assert len(rows) == expected and {r["class"] for r in rows} == {"block"}
    coco = json.loads((out / "coco" / "annotations.json").read_text())
    assert len(coco["annotations"]) == expected
    assert len(list((out / "pointclouds").glob("*.ply"))) == 5

    inspected = datagen("inspect", str(out))
    assert inspected.returncode == 0, inspected.stderr

    refused = datagen("export", str(out), "--to", "usd")
    assert refused.returncode != 0 and "Traceback" not in refused.stderr
    assert "usd" in refused.stderr and "example_blocks" in refused.stderr


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_failing_sample_is_retried_from_its_own_streams(tmp_path):
    config = config_file(tmp_path)
    one = datagen("build", str(config), "--out", str(tmp_path / "a"), "--workers", "1", "--no-preview", faults="2:1")  # fmt: skip
    assert one.returncode == 0, one.stderr
    two = datagen("build", str(config), "--out", str(tmp_path / "b"), "--workers", "2", "--no-preview", faults="2:2")  # fmt: skip
    assert two.returncode == 0, two.stderr
    a, b = samples(tmp_path / "a"), samples(tmp_path / "b")
    assert sorted(a) == sorted(b) == [f"{i:09d}" for i in range(5)]
    for key in a:  # only sample 2 was retried, and it is a function of (seed, index, attempt)
        if key != "000000002":
            assert a[key] == b[key]
    first = json.loads(a["000000002"]["json"])["production"]
    second = json.loads(b["000000002"]["json"])["production"]
    assert first["attempt"] == 1 and len(first["failures"]) == 1
    assert second["attempt"] == 2 and len(second["failures"]) == 2
    assert "injected fault in sample 2, attempt 0" in first["failures"][0]
    assert all("production" not in json.loads(a[k]["json"]) for k in a if k != "000000002")
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert manifest["retried_samples"]["2"]["attempt"] == 1


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_samples_failing_every_attempt_fail_the_build_listing_them_and_resume_finishes(tmp_path):
    config, out = config_file(tmp_path, "build: {retries: 2}\n"), tmp_path / "out"
    # 3 workers: the resume has 2 samples to make, so it dismisses one of the workers it started
    # before the writer said what is durable (datagen/pipeline/coordinator.py, _dismiss)
    failed = datagen("build", str(config), "--out", str(out), "--workers", "3", "--no-preview", faults="1:99,3:99")  # fmt: skip
    assert failed.returncode == 1
    assert "Traceback" not in failed.stderr
    assert "2 of 5 samples failed on every attempt" in failed.stderr
    assert "[1, 3]" in failed.stderr and "injected fault in sample 3, attempt 2" in failed.stderr
    assert not (out / "manifest.json").exists()
    # the failure prints the whole command that finishes the build; run it as printed
    printed = re.search(r"finish it with: (.+)", failed.stderr)[1].split()
    assert printed[:2] == ["datagen", "build"] and printed[-1] == "--resume"
    resumed = datagen(*printed[1:])
    assert resumed.returncode == 0, resumed.stderr
    assert "3 were already durable" in resumed.stdout
    assert len(load(out)) == 5


@pytest.mark.sim
@pytest.mark.mqtt
def test_policy_fail_stops_at_the_first_failing_sample(tmp_path):
    config = config_file(tmp_path, "build: {on_sample_error: fail}\n")
    failed = datagen("build", str(config), "--out", str(tmp_path / "out"), "--workers", "1", "--no-preview", faults="0:1")  # fmt: skip
    assert failed.returncode == 1 and "Traceback" not in failed.stderr
    assert "sample 0 failed 1 time(s)" in failed.stderr and "on_sample_error: fail" in failed.stderr


def test_plugin_names_are_choices_of_the_config_and_the_cli():
    script = (
        "from datagen.config import config_from_dict\n"
        "c = config_from_dict({'scene': 'grasp_attempts', 'campaign': {'sampler': 'top_down'}})\n"
        "print(c.campaign.sampler)\n"
    )
    path = os.pathsep.join([str(PLUGINS), os.environ.get("PYTHONPATH", "")])
    env = os.environ | {"PYTHONPATH": path}
    ran = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env)
    assert ran.stdout.strip() == "top_down", ran.stderr
    helped = datagen("campaign", "grasp", "x.yaml", "--out", "x", "--sampler", "nope")
    assert helped.returncode == 2
    assert "expected one of ['antipodal', 'random', 'learned', 'top_down']" in helped.stderr


def test_the_example_sampler_grasps_a_box_from_above():
    sys.path.insert(0, str(PLUGINS))
    try:
        from example_top_down import TopDownSampler
    finally:
        sys.path.remove(str(PLUGINS))
    from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
    from datagen.families.grasp_attempts.samplers.base import GraspTarget, Obstacles
    from datagen.registries import ROBOTS

    box = trimesh.creation.box(extents=[0.04, 0.1, 0.05])
    box.apply_translation([0.1, 0.0, 0.775])
    result = TopDownSampler(gripper_geometry(ROBOTS["panda"].load())).sample(np.random.default_rng(0), GraspTarget([box], np.eye(4)), Obstacles([]))  # fmt: skip
    candidate = result.candidate
    assert candidate is not None and candidate.width == pytest.approx(0.05)
    assert np.allclose(candidate.approach, [0, 0, -1]) and np.allclose(candidate.closing, [1, 0, 0])


# run with the plug-ins on the path: datagen's own loader, views and episodes on the dataset
READ_ROLLS = """
import json, sys
from datagen.dataset.loader import load
from datagen.dataset.views import is_sequence, labelled_views
from datagen.exports.episodes import episodes
dataset = load(sys.argv[1])
item = dataset[0]
views = labelled_views(item["meta"])
print(json.dumps({
    "frames": [sorted(f) for f in item["frames"]],
    "views": [v.name for v in views], "sequence": is_sequence(views),
    "things": [len(v.instances) for v in views],
    "episodes": [(i, e.key, e.length, e.fps) for i, e in episodes(dataset, dataset.manifest)],
}))
"""
READ_LEROBOT = """
import json, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
ds = LeRobotDataset("example/rolls", root=sys.argv[1], video_backend="pyav")
frame = ds[ds.num_frames - 1]
print(json.dumps({
    "episodes": ds.num_episodes, "frames": ds.num_frames, "fps": ds.fps,
    "robot_type": ds.meta.robot_type, "cameras": list(ds.meta.camera_keys),
    "state": frame["observation.state"].tolist(), "task": frame["task"],
}))
"""


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_plugin_family_with_its_own_metadata_format_gets_every_reader_tool_and_export(
    tmp_path, readers_python
):
    """docs/extending.md's walk, as printed: example_rolls writes episodes in a format of its own
    (tests/plugins/example_roll_format.py, one entry point); the loader, the views, inspect,
    preview, the card, COCO and the LeRobot export read them through that module alone."""
    doc = (REPO / "docs" / "extending.md").read_text()
    walk = doc.split("<!-- snippet: tested by tests/test_extending.py -->\n```bash\n")[1]
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"
    ran = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", walk.split("```")[0]],
        capture_output=True, text=True, cwd=tmp_path, timeout=600, check=False,
        env=os.environ | {"PYTHONPATH": str(PLUGINS), "PATH": path},
    )  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]
    out = tmp_path / "datasets" / "rolls"
    assert (out / "preview.png").is_file()  # drawn by the format's tile
    card = (out / "README.md").read_text()
    assert "mean_roll_m" in card or "mean roll m" in card, card[:3000]  # the format's summary

    read = subprocess.run(
        [sys.executable, "-c", READ_ROLLS, str(out)],
        capture_output=True, text=True, cwd=REPO, timeout=300, check=False,
        env=os.environ | {"PYTHONPATH": str(PLUGINS)},
    )  # fmt: skip
    assert read.returncode == 0, read.stderr[-3000:]
    found = json.loads(read.stdout.strip().splitlines()[-1])
    assert found["frames"] == [["depth", "meta", "rgb", "seg", "semantic"]] * 6
    assert found["views"] == [f"f{k:04d}" for k in range(6)] and found["sequence"]
    assert found["things"][0] == 1  # the ball, seen from above
    assert [e[:3] for e in found["episodes"]] == [[i, f"{i:09d}", 6] for i in range(3)]

    summary = json.loads((out / "inspect" / "summary.json").read_text())
    assert summary["episodes"] == 3 and summary["frames"] == 18 and summary["mean_roll_m"] > 0
    assert (out / "inspect" / "overview.png").is_file()
    assert (out / "inspect" / "distributions.png").is_file()

    coco = json.loads((out / "coco" / "annotations.json").read_text())
    assert len(coco["images"]) == 18 and {c["name"] for c in coco["categories"]} == {"ball"}
    lerobot = subprocess.run(
        [str(readers_python), "-c", READ_LEROBOT, str(out / "lerobot")],
        capture_output=True, text=True, cwd=tmp_path, timeout=300, check=False,
        env=os.environ | {"HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1", "HF_HOME": str(tmp_path / "hf")},
    )  # fmt: skip
    assert lerobot.returncode == 0, lerobot.stderr[-3000:]
    got = json.loads(lerobot.stdout.strip().splitlines()[-1])
    assert got["episodes"] == 3 and got["frames"] == 18 and got["fps"] == 10
    assert got["robot_type"] == "ball" and got["cameras"] == ["observation.images.top"]
    last = load(out).metadata(2)["frames"][-1]["ball_xy"]
    assert np.allclose(got["state"], last, atol=1e-5) and got["task"] == "roll the ball"


ROVER = """\
scene: navigation
num_samples: 1
seed: 4
render: {width: 96, height: 72}
navigation: {robot: rover, family: corridor, frame_rate_hz: 2}
"""


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_third_ground_robot_is_one_record_and_one_entry_point(tmp_path):
    """tests/plugins/example_rover.py: its record (drive, body, description, view limit) and
    one entry point; navigation episodes, inspect and the LeRobot export take it as they take
    Fetch and the car."""
    config, out = tmp_path / "rover.yaml", tmp_path / "rover"
    config.write_text(ROVER)
    built = datagen("build", str(config), "--out", str(out), "--workers", "1")
    assert built.returncode == 0, built.stderr[-3000:]
    meta = load(out).metadata(0)
    assert meta["robot"]["name"] == "rover" and meta["robot"]["size_m"][0] > 0
    things = {t["class"] for f in meta["frames"] for t in f["things"]}
    assert "robot" not in things  # its camera never lists itself
    assert len(meta["frames"]) >= 2 and meta["episode"]["path_length_m"] > 0
    exported = datagen("export", str(out), "--to", "lerobot")
    assert exported.returncode == 0, exported.stderr[-3000:]
    info = json.loads((out / "lerobot" / "meta" / "info.json").read_text())
    assert info["robot_type"] == "rover"

    steep = config.read_text().replace("frame_rate_hz: 2}", "camera_pitch_deg: [60, 70]}")
    config.write_text(steep)
    refused = datagen("build", str(config), "--out", str(tmp_path / "steep"), "--check")
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert "the rover camera's view would reach" in refused.stderr
    assert "expected at most 80" in refused.stderr  # the record's own limit
    config.write_text(ROVER.replace("robot: rover", "robot: tank"))
    unknown = datagen("build", str(config), "--out", str(tmp_path / "tank"), "--check")
    assert unknown.returncode == 2 and "'fetch', 'car', 'rover'" in unknown.stderr


HEXAROTOR = """\
scene: aerial
num_samples: 1
seed: 2
render: {width: 96, height: 72}
aerial: {airframe: hexarotor, drones: 2, family: corridor, frame_rate_hz: 2}
"""


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_second_airframe_is_one_record_and_one_entry_point(tmp_path):
    """tests/plugins/example_hexarotor.py: its shape, parts, paint and camera mounts in one
    record and one entry point; aerial episodes are planned with its radius, drawn with its
    parts and exported as its robot."""
    config, out = tmp_path / "hex.yaml", tmp_path / "hex"
    config.write_text(HEXAROTOR)
    built = datagen("build", str(config), "--out", str(out), "--workers", "1")
    assert built.returncode == 0, built.stderr[-3000:]
    meta = load(out).metadata(0)
    assert set(meta["randomisation"]["drones"][0]) == {"body", "arms", "rotors", "camera"}
    for frame in meta["frames"]:  # each drone's camera never sees its own drone
        for k in range(2):
            seen = {t["name"] for t in frame["cameras"][f"d{k}"]["things"]}
            assert f"drone_{k}" not in seen
    exported = datagen("export", str(out), "--to", "lerobot")
    assert exported.returncode == 0, exported.stderr[-3000:]
    info = json.loads((out / "lerobot" / "meta" / "info.json").read_text())
    assert info["robot_type"] == "hexarotor"
    config.write_text(HEXAROTOR.replace("hexarotor", "octocopter"))
    unknown = datagen("build", str(config), "--out", str(tmp_path / "octo"), "--check")
    assert unknown.returncode == 2 and "'quadrotor', 'hexarotor'" in unknown.stderr
