"""The preview tile of an aerial episode: the middle frame of the first drone's forward camera
with every labelled instance boxed and the drone's state written on it, beside its depth and its
optical flow (hue = direction, brightness = length; black where invalid), above the episode's
top-down and side pictures with the planned and flown paths."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from datagen.tools.drawing import depth_colour, fit, instance_colour, put_label
from datagen.tools.sample_checks import pixel_box


def flow_colour(flow: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 BGR: hue from the flow's direction, value from its length (the 99th
    percentile full)."""
    length = np.hypot(flow[..., 0], flow[..., 1])
    top = max(float(np.percentile(length[valid], 99)) if valid.any() else 1.0, 1e-6)
    hsv = np.zeros((*flow.shape[:2], 3), np.uint8)
    hsv[..., 0] = ((np.arctan2(flow[..., 1], flow[..., 0]) + np.pi) / (2 * np.pi) * 179).astype(
        np.uint8
    )
    hsv[..., 1] = 255
    hsv[..., 2] = (np.clip(length / top, 0, 1) * 255).astype(np.uint8) * valid
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)


def aerial_tile(item: dict[str, Any]) -> np.ndarray:
    meta, frames = item["meta"], item["frames"]
    k = len(frames) // 2
    camera = sorted(meta["cameras"])[0]
    images, record = frames[k]["cameras"][camera], meta["frames"][k]
    image = cv2.cvtColor(images["rgb"], cv2.COLOR_RGB2BGR)
    for thing in record["cameras"][camera]["things"]:
        x0, y0, x1, y1 = pixel_box(thing["bbox_xyxy"], "frames[].cameras[].things[].bbox_xyxy")
        cv2.rectangle(image, (x0, y0), (x1, y1), instance_colour(int(thing["instance_id"])), 1)
        put_label(image, str(thing["name"])[:24], (x0 + 2, max(10, y0 + 12)), 0.35)
    state = record["agents"][meta["cameras"][camera]["drone"]]
    speed = float(np.linalg.norm(state["velocity"]))
    put_label(image, f"{item['key']} {camera} f{k}/{len(frames)} {meta['family']}", (6, 16), 0.45)
    put_label(
        image,
        f"z={state['position'][2]:.2f}m v={speed:.2f}m/s thrust={state['thrust']:.1f}",
        (6, image.shape[0] - 24),
        0.4,
    )
    put_label(
        image,
        f"goal {state['distance_to_goal']:.2f}m gap {state['obstacle_gap']:.2f}m",
        (6, image.shape[0] - 8),
        0.4,
    )
    h = image.shape[0]
    flow = images.get("flow")
    motion = flow_colour(flow, images["flow_valid"]) if flow is not None else np.zeros_like(image)
    top = np.hstack([image, depth_colour(images["depth"]), motion])
    episode = meta["episode"]
    outcome = "success" if episode["success"] else "failure"
    plan = np.hstack(
        [
            fit(cv2.cvtColor(item["map"], cv2.COLOR_RGB2BGR), 2 * h, top.shape[1] // 2),
            fit(
                cv2.cvtColor(item["side"], cv2.COLOR_RGB2BGR),
                2 * h,
                top.shape[1] - top.shape[1] // 2,
            ),
        ]
    )
    put_label(
        plan,
        f"{outcome}: {len(episode['agents'])} drone(s), SPL {episode['spl']:.2f}",
        (6, 18),
        0.5,
    )
    return np.vstack([top, plan])
