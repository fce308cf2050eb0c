"""Run in the readers' environment: reads a LeRobot export written with ``--lerobot-robot`` as
lerobot 0.4.4 would, next to that arm's own description. Instantiates the arm's lerobot robot
class without hardware (its config with a port that is never opened), takes its
``observation_features`` and ``action_features`` through ``hw_to_dataset_features`` (what
``lerobot-record`` writes) and its ``robot_type``; loads the export with ``LeRobotDataset``; and
puts the export's stated calibration (``meta/info.json`` ``datagen.calibration``) on the robot's
motor bus, whose own ``_normalize`` turns datagen's joint angles (given per episode, in radians)
into lerobot's readings and ``_unnormalize`` turns those back into steps, then radians.

Usage: python lerobot_arm_reader.py ARGS.json, ARGS: {"root", "robot", "units", "calibration_dir",
"radians": {datagen key: {"state": [[rad, ...]], "action": [[rad, ...]]}}}; prints JSON."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.datasets.utils import hw_to_dataset_features
from lerobot.motors.motors_bus import MotorCalibration
from lerobot.robots import koch_follower, so_follower  # registers their robot configs
from lerobot.robots.config import RobotConfig
from lerobot.robots.utils import make_robot_from_config

CALIBRATION_FIELDS = ("id", "drive_mode", "homing_offset", "range_min", "range_max")
ARMS = (koch_follower, so_follower)


def _robot(args: dict):
    config_class = RobotConfig.get_choice_class(args["robot"])
    config = config_class(
        port="/dev/null",  # never opened: nothing here connects
        id="datagen",
        calibration_dir=Path(args["calibration_dir"]),
        use_degrees=args["units"] == "degrees",
    )
    return make_robot_from_config(config)


def _through_the_bus(bus, calibration: dict, rows: list[list[float]]) -> tuple[list, list]:
    """lerobot's readings of joint angles (rad) under ``calibration``, and those readings
    turned back into steps and then radians."""
    motors = list(calibration)
    read, back = [], []
    for row in rows:
        raw, span = {}, {}
        for motor, q in zip(motors, row, strict=True):
            c = calibration[motor]
            span[motor] = (c["upper_rad"] - c["lower_rad"]) / (c["range_max"] - c["range_min"])
            raw[c["id"]] = c["range_min"] + (q - c["lower_rad"]) / span[motor]
        values = bus._normalize(raw)  # lerobot's own reading of a raw position
        steps = bus._unnormalize(values)  # and of a goal position (whole steps)
        ids = [calibration[m]["id"] for m in motors]
        read.append([values[i] for i in ids])
        back.append(
            [
                calibration[m]["lower_rad"] + (steps[i] - calibration[m]["range_min"]) * span[m]
                for i, m in zip(ids, motors, strict=True)
            ]
        )
    return read, back


def main(args: dict) -> None:
    robot = _robot(args)
    ds = LeRobotDataset("datagen/arm", root=args["root"], video_backend="pyav")
    stated = ds.meta.info["datagen"]
    calibration = stated["calibration"]
    robot.bus.calibration = {
        motor: MotorCalibration(**{k: c[k] for k in CALIBRATION_FIELDS})
        for motor, c in calibration.items()
    }
    columns = ds.hf_dataset.with_format(None)
    episodes = {}
    for e in ds.meta.episodes:
        rows = range(int(e["dataset_from_index"]), int(e["dataset_to_index"]))
        radians = args["radians"][e["datagen/key"]]
        state, state_back = _through_the_bus(robot.bus, calibration, radians["state"])
        action, action_back = _through_the_bus(robot.bus, calibration, radians["action"])
        episodes[e["datagen/key"]] = {
            "exported_state": [columns[i]["observation.state"] for i in rows],
            "exported_action": [columns[i]["action"] for i in rows],
            "lerobot_state": state,
            "lerobot_action": action,
            "back_state": state_back,
            "back_action": action_back,
        }
    print(
        json.dumps(
            {
                "robot_type": robot.robot_type,
                "dataset_robot_type": ds.meta.robot_type,
                "robot_features": {
                    **hw_to_dataset_features(robot.observation_features, "observation"),
                    **hw_to_dataset_features(robot.action_features, "action"),
                },
                "features": {k: ds.features[k] for k in ("observation.state", "action")},
                "norm_modes": {m: motor.norm_mode.value for m, motor in robot.bus.motors.items()},
                "stated": {k: v for k, v in stated.items() if k != "calibration"},
                "episodes": episodes,
            },
            default=list,
        )
    )


if __name__ == "__main__":
    main(json.loads(Path(sys.argv[1]).read_text()))
