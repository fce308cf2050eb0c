"""The LeRobot export in lerobot's own arms' terms (``--lerobot-robot``, docs/export-lerobot.md),
of real so100 and koch campaigns built by the command line, read in the readers' environment next
to lerobot 0.4.4's ``so100_follower`` and ``koch_follower`` robot classes
(``lerobot_arm_reader.py``): the state and action features are the ones ``lerobot-record``
writes for that robot (names, order, dtype, shape), robot_type is the robot's, and every exported
value is what the robot's own motor bus reads of datagen's joint angle under the calibration the
export states, and reads back to within one motor step."""

from __future__ import annotations

import json
import math
import re
import shlex
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

import datagen
from datagen.cli.dataset_commands import LEROBOT_ROBOTS, LEROBOT_UNITS
from datagen.exports.episodes import episodes
from datagen.exports.lerobot_robots import ARMS, UNITS

pytestmark = pytest.mark.sim
REPO = Path(__file__).resolve().parents[2]
READER = Path(__file__).with_name("lerobot_arm_reader.py")
DOC = REPO / "docs" / "export-lerobot.md"
# datagen's joints of each lerobot motor, in lerobot's motor order (shoulder_pan .. gripper)
JOINTS = {
    "so100": ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"],
    "koch": [f"joint_{k}" for k in range(1, 7)],
}
STEP_RAD = 2 * math.pi / 4096  # one motor step
BUILDS = {"so100": (5, 2), "koch": (1, 3)}  # seed, attempts: some attempts find a grasp to film


def _campaign(robot: str, tmp: Path) -> Path:
    """A few attempts of ``robot``, filmed at 64x48 with the rows, at 10 Hz."""
    seed, attempts = BUILDS[robot]
    config = {
        "version": 1,
        "scene": "grasp_attempts",
        "num_samples": attempts,
        "seed": seed,
        "robot": {"name": robot},
        "render": {"width": 64, "height": 48},
        "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 10, "frame_hz": 10},
    }
    path, out = tmp / f"{robot}.yaml", tmp / robot
    path.write_text(yaml.safe_dump(config))
    command = [sys.executable, "-m", "datagen.cli", "campaign", "grasp", str(path)]
    done = subprocess.run(
        [*command, "--out", str(out), "--workers", "1"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=900,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def arm_campaigns(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("arms")
    return {robot: _campaign(robot, tmp) for robot in JOINTS}


def _export(source: Path, root: Path, *flags: str) -> subprocess.CompletedProcess:
    shutil.copytree(source, root)
    command = [sys.executable, "-m", "datagen.cli", "export", str(root), *flags]
    return subprocess.run(command, capture_output=True, text=True, cwd=REPO, timeout=300)


def _page_command() -> list[str]:
    marker = "<!-- snippet: tested by tests/exports/test_lerobot_arms.py -->"
    found = re.findall(re.escape(marker) + r"\n```bash\n(.*?)```", DOC.read_text(), re.S)
    assert len(found) == 1, "export-lerobot.md: one snippet tested here"
    command = shlex.split(found[0])
    assert command[:3] == ["datagen", "export", "datasets/so100_campaign"]
    return command


def _radians(root: Path, robot: str) -> dict[str, dict[str, list]]:
    """datagen's own episodes (radians), per sample key, columns in lerobot's motor order."""
    dataset = datagen.load(root)
    manifest = json.loads((root / "manifest.json").read_text())
    out = {}
    for _, episode in episodes(dataset, manifest):
        state = [episode.state_names.index(j) for j in JOINTS[robot]]
        action_names = [*JOINTS[robot][:-1], "finger_target"]  # the jaw's drive target, rad
        action = [episode.action_names.index(j) for j in action_names]
        out[episode.key] = {
            "state": episode.state[:, state].astype(float).tolist(),
            "action": episode.action[:, action].astype(float).tolist(),
        }
    return out


@pytest.mark.parametrize(
    ("robot", "name", "units"),
    [
        ("so100", "so100_follower", None),
        ("koch", "koch_follower", None),
        ("so100", "so100_follower", "range_m100_100"),
    ],
)
def test_lerobot_export_in_a_lerobot_arms_terms(
    robot, name, units, arm_campaigns, readers_python, tmp_path
):
    root = tmp_path / robot
    flags = ["--to", "lerobot", "--lerobot-robot", name]
    flags += ["--lerobot-units", units] if units else []
    if (robot, units) == ("so100", None):  # the page's command, as printed
        assert flags == _page_command()[3:]
    done = _export(arm_campaigns[robot], root, *flags)
    assert done.returncode == 0, done.stderr[-3000:]
    radians = _radians(root, robot)
    units = units or ARMS[name].units
    args = {
        "root": str(root / "lerobot"),
        "robot": name,
        "units": units,
        "calibration_dir": str(tmp_path / "calibration"),
        "radians": radians,
    }
    (tmp_path / "args.json").write_text(json.dumps(args))
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "HF_HUB_OFFLINE": "1"}
    ran = subprocess.run(
        [str(readers_python), str(READER), str(tmp_path / "args.json")],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
        cwd=tmp_path,
    )
    assert ran.returncode == 0, ran.stderr[-3000:]
    read = json.loads(ran.stdout.strip().splitlines()[-1])
    assert read["features"] == read["robot_features"]  # names, order, dtype, shape
    assert read["dataset_robot_type"] == read["robot_type"]
    body = {m: units for m in read["norm_modes"] if m != "gripper"} | {"gripper": "range_0_100"}
    assert read["norm_modes"] == body and read["stated"]["units"] == units
    assert read["stated"]["lerobot_robot"] == name and set(read["episodes"]) == set(radians)
    for key, got in read["episodes"].items():
        for part in ("state", "action"):
            exported = np.array(got[f"exported_{part}"])
            assert np.abs(exported - got[f"lerobot_{part}"]).max() < 1e-3, (key, part)
            limits = np.array([motor[2:] for motor in ARMS[name].motors])
            q = np.clip(radians[key][part], limits[:, 0], limits[:, 1])  # lerobot clamps too
            assert np.abs(np.array(got[f"back_{part}"]) - q).max() <= STEP_RAD + 1e-9, key


@pytest.mark.parametrize("robot", ["so100", "koch"])
def test_the_stated_joint_limits_are_the_urdfs(robot):
    from datagen.robot_specs import koch, so100

    urdf = {"so100": so100.urdf, "koch": koch.urdf}[robot]()
    limits = {
        j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
        for j in ET.parse(urdf).getroot().iter("joint")
        if j.get("type") == "revolute"
    }
    arm = next(arm for arm in ARMS.values() if arm.datagen_robot == robot)
    assert {joint: (lo, hi) for _, joint, lo, hi in arm.motors} == limits


def test_the_robot_option_is_refused_in_one_line(arm_campaigns, tmp_path):
    assert tuple(sorted(ARMS)) == LEROBOT_ROBOTS and UNITS == LEROBOT_UNITS
    cases = [
        (["--to", "lerobot", "--lerobot-robot", "so100_follower"], "maps datagen's so100 arm"),
        (["--to", "hdf5", "--lerobot-robot", "koch_follower"], "add lerobot to --to"),
        (["--to", "lerobot", "--lerobot-units", "degrees"], "needs --lerobot-robot"),
    ]
    for k, (flags, said) in enumerate(cases):
        root = tmp_path / f"koch{k}"
        done = _export(arm_campaigns["koch"], root, *flags)
        assert done.returncode == 2 and said in done.stderr, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and not (root / "lerobot").exists()
