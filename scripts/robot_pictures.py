"""The pictures of docs/robots.md: sample 0 of each built-in arm's grasp config, rendered by a
real build's producer: its workspace view with the robot and gripper pixels outlined, and its
wrist camera's view beside it.

    .venv/bin/python scripts/robot_pictures.py docs/images/robots
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np

from datagen.config import load_config
from datagen.registries import FAMILIES, ROBOTS

REPO = Path(__file__).resolve().parents[1]


def picture(name: str) -> np.ndarray:
    config = load_config(
        REPO / "configs" / ("grasp_tabletop.yaml" if name == "panda" else f"grasp_{name}.yaml")
    )
    sample = FAMILIES["grasp_tabletop"].produce_sample(config, config.seed, 0)
    classes = json.loads(sample.parts["json"])["classes"]
    views = [_outlined(sample.parts, prefix, classes) for prefix in ("", "wrist.")]
    cv2.putText(views[0], name, (12, 32), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (255, 255, 255), 2)
    return np.hstack(views)


def _outlined(parts: dict[str, bytes], prefix: str, classes: list[str]) -> np.ndarray:
    """A camera's colour image with its robot and gripper pixels outlined."""
    rgb = cv2.imdecode(np.frombuffer(parts[f"{prefix}rgb.png"], np.uint8), cv2.IMREAD_COLOR)
    labels = cv2.imdecode(
        np.frombuffer(parts[f"{prefix}semantic.png"], np.uint8), cv2.IMREAD_UNCHANGED
    )
    for colour, label in (((0, 200, 255), "robot"), ((255, 80, 0), "gripper")):
        if label in classes:
            mask = (labels == classes.index(label)).astype(np.uint8)
            contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            cv2.drawContours(rgb, contours, -1, colour, 2)
    return rgb


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name in sorted(ROBOTS):
        path = out / f"{name}.jpg"
        cv2.imwrite(
            str(path), cv2.resize(picture(name), (640, 240)), [cv2.IMWRITE_JPEG_QUALITY, 80]
        )
        print(path, path.stat().st_size, "bytes")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
