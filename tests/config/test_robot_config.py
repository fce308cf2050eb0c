"""``robot.name`` and ``robot.urdf``: the arm a config chooses, and one-line errors for what is
wrong with it (pure: reads URDF files, no simulator)."""

from __future__ import annotations

import pytest

from datagen.config import config_from_dict
from datagen.config.robot import robot_spec
from datagen.errors import ConfigError
from datagen.registries import ROBOTS

PANDA_URDF = str(ROBOTS["panda"].load().urdf_path())
USER = {
    "file": PANDA_URDF,
    "arm_joints": [f"panda_joint{i}" for i in range(1, 8)],
    "finger_joints": ["panda_finger_joint1", "panda_finger_joint2"],
    "tcp_link": "panda_hand_tcp",
}


def test_every_built_in_arm_is_chosen_by_name():
    assert {"panda", "iiwa14", "xarm7"} <= set(ROBOTS)
    for name in ROBOTS:
        spec = robot_spec(config_from_dict({"robot": {"name": name}}).robot)
        assert spec.name == name and len(spec.ready_pose) == len(spec.arm_joints)


def test_an_unknown_arm_lists_the_choices():
    with pytest.raises(ConfigError, match=r"x.yaml: robot.name: expected one of \['panda'"):
        config_from_dict({"robot": {"name": "ur5"}}, source="x.yaml")


def test_a_user_urdf_becomes_a_robot_record():
    config = config_from_dict({"robot": {"name": "mine", "urdf": USER}})
    spec = robot_spec(config.robot)
    assert spec.gripper.hand_link == "panda_hand"
    assert spec.gripper.finger_links == ("panda_leftfinger", "panda_rightfinger")
    assert spec.ready_pose == pytest.approx([0.0, 0.0, 0.0, -1.5708, 0.0, 1.8675, 0.0], abs=1e-3)
    assert 0.855 < spec.reach < 1.5  # an upper bound: the joint offsets from the base to the TCP


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"name": "panda"}, r"robot.name: a robot from robot.urdf.file needs a name of its own"),
        ({"urdf": USER | {"file": "missing.urdf"}}, r"robot.urdf.file: expected a URDF file"),
        ({"urdf": USER | {"arm_joints": ["nope"]}}, r"robot.urdf.arm_joints: .* got 'nope'"),
        (
            {"urdf": USER | {"finger_joints": ["panda_joint1", "panda_finger_joint2"]}},
            r"robot.urdf.finger_joints: expected prismatic joints .* \(revolute\)",
        ),
        ({"urdf": USER | {"tcp_link": "tip"}}, r"robot.urdf.tcp_link: expected a link"),
        ({"urdf": USER | {"ready_pose": [0.0]}}, r"robot.urdf.ready_pose: expected 7 values"),
        ({"urdf": USER | {"typo": 1}}, r"unknown key\(s\) robot.urdf.typo"),
    ],
)
def test_a_wrong_user_arm_is_one_line_naming_the_key(change, message):
    robot = {"name": "mine", "urdf": USER} | change
    with pytest.raises(ConfigError, match=message):
        config_from_dict({"robot": robot}, source="x.yaml")


def test_a_urdf_that_is_not_one_is_named(tmp_path):
    bad = tmp_path / "arm.urdf"
    bad.write_text("<robot><link")
    with pytest.raises(ConfigError, match=r"arm.urdf: not a readable URDF"):
        config_from_dict({"robot": {"name": "mine", "urdf": USER | {"file": str(bad)}}})
