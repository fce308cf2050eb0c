"""The pictures of docs/aerial.md and the README: episode 0 of each shipped aerial config,
produced as a build produces it, drawn as ``datagen preview`` draws an aerial episode (the middle
frame of the first drone's forward camera with its labels, depth and optical flow, above the
top-down and side pictures with the planned and flown paths).

    .venv/bin/python scripts/aerial_pictures.py docs/images
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2

from datagen.config import load_config
from datagen.dataset.loader import decode_parts
from datagen.registries import FAMILIES
from datagen.tools.preview import sample_tile

REPO = Path(__file__).resolve().parents[1]
FAMILIES_SHOWN = ("corridor", "maze", "rooms")


def main(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    for family in FAMILIES_SHOWN:
        config = load_config(REPO / "configs" / f"aerial_{family}.yaml")
        sample = FAMILIES["aerial"].produce_sample(config, config.seed, 0)
        item = decode_parts(sample.parts) | {"key": f"aerial_{family}"}
        path = out / f"aerial_{family}.jpg"
        cv2.imwrite(str(path), sample_tile(item), [cv2.IMWRITE_JPEG_QUALITY, 85])
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "docs/images")))
