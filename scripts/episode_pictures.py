"""The pictures of docs/aerial.md, docs/navigation.md (the car in the four-arm maze) and the
README: episode 0 of each shipped aerial config and of configs/nav_plus_maze_car.yaml, produced as
a build produces it, drawn as ``datagen preview`` draws an episode (aerial: the middle frame of the
first drone's forward camera with its labels, depth and optical flow, above the top-down and side
pictures with the planned and flown paths; ground: the middle frame above the map).

    .venv/bin/python scripts/episode_pictures.py docs/images
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2

from datagen.config import load_config
from datagen.dataset.parts import decode_parts
from datagen.registries import FAMILIES
from datagen.tools.preview import sample_tile

REPO = Path(__file__).resolve().parents[1]
SHOWN = ("aerial_corridor", "aerial_maze", "aerial_rooms", "nav_plus_maze_car")  # configs/NAME.yaml


def main(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    for name in SHOWN:
        config = load_config(REPO / "configs" / f"{name}.yaml")
        sample = FAMILIES[config.scene].produce_sample(config, config.seed, 0)
        item = decode_parts(sample.parts) | {"key": name}
        path = out / f"{name}.jpg"
        cv2.imwrite(str(path), sample_tile(item), [cv2.IMWRITE_JPEG_QUALITY, 85])
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "docs/images")))
