"""The metadata format ``example.roll/1`` of the ``example_rolls`` family: one camera over time
(parts ``f0003.rgb.png``, ...; records in ``frames``), the ball's position per frame. Every
function datagen asks a format for (``datagen/formats/__init__.py``), in one module."""

from __future__ import annotations

import cv2
import numpy as np

from datagen.dataset.episode_parts import FRAME_IMAGES
from datagen.dataset.views import sequence_views
from datagen.exports.episodes import Episode
from datagen.registries import MetadataFormat

views = sequence_views  # one camera over time: a shape datagen.dataset.views has
PARTS = (FRAME_IMAGES,)  # its frames' images, read as one camera over time (the rule datagen has)


def summary(metas):
    travelled = [
        float(np.linalg.norm(np.subtract(m["frames"][-1]["ball_xy"], m["frames"][0]["ball_xy"])))
        for m in metas
    ]
    return {
        "episodes": len(metas),
        "frames": sum(len(m["frames"]) for m in metas),
        "mean_roll_m": round(float(np.mean(travelled)), 4),
    }


def distributions(metas):
    return {
        "speed (m/s)": [float(np.hypot(*m["randomisation"]["roll"]["velocity"])) for m in metas],
        "frames with the ball seen": [sum(bool(f["things"]) for f in m["frames"]) for m in metas],
    }


def summary_fields(meta):
    return {
        "format": meta["format"],
        "frames": [{"ball_xy": f["ball_xy"]} for f in meta["frames"]],
    }


def tile(item):
    """The first and the last frame side by side, the ball's track drawn on the last."""
    first, last = item["frames"][0]["rgb"], item["frames"][-1]["rgb"]
    image = cv2.cvtColor(np.hstack([first, last]), cv2.COLOR_RGB2BGR)
    cv2.putText(image, item["key"], (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
    return image


def episodes(meta, dataset, i, manifest):
    frames = meta["frames"]
    xy = np.array([f["ball_xy"] for f in frames], np.float32)
    velocity = np.array(meta["randomisation"]["roll"]["velocity"], np.float32)
    return [
        Episode(
            key=meta["key"],
            kind="roll",
            task="roll the ball",
            robot="ball",
            fps=float(meta["fps"]),
            state=xy,
            state_names=["x", "y"],
            action=np.tile(velocity, (len(frames), 1)),
            action_names=["vx_m_s", "vy_m_s"],
            success=True,
            cameras={"top": [f"f{f['frame']:04d}.rgb.png" for f in frames]},
            depth={"top": [f"f{f['frame']:04d}.depth.png" for f in frames]},
        )
    ]


FORMAT = MetadataFormat(
    "example.roll/1",
    "a ball rolling across a floor: one camera over time",
    "example_roll_format",
    noun="episodes",
)
