"""What a worker tells people watching the build: a small annotated JPEG of a sample it made,
at most one a second, at QoS 0 on ``datagen/<build_id>/live/preview/<worker>`` (never
waited for: a preview can be lost), and each sample's outcome (a grasp attempt's success, a
navigation episode's success and SPL) for the coordinator's live status. Making a preview
takes the worker ~10 ms of CPU (640x480, mostly decoding the PNGs again), so the feed spaces
them to spend at most ``PREVIEW_BUDGET`` of the worker's time on them: one every 2 s at that
cost.

A preview is a thumbnail: the colour image with instance masks blended in and 2-D boxes
(``datagen inspect`` draws the full annotations), or a navigation episode's top-down map.
Unsigned, like the live status: see ``datagen/pipeline/live_status.py``.
"""

from __future__ import annotations

import logging
import time
from typing import cast

import cv2
import numpy as np

from datagen import outcomes
from datagen.dataset.views import labelled_views
from datagen.images import decode_image
from datagen.pipeline.live_status import live_enabled
from datagen.records import SampleOutcome
from datagen.sample import Sample
from datagen.transport.connection import MqttConnectError, MqttConnection
from datagen.transport.run_binding import client_id
from datagen.transport.topics import topics

log = logging.getLogger(__name__)
PREVIEW_PERIOD_S = 1.0  # at most one preview a second per worker
PREVIEW_BUDGET = 0.005  # and at most this fraction of the worker's time
PREVIEW_WIDTH = 240  # pixels; the height keeps the aspect ratio
JPEG_QUALITY = 80


def sample_outcome(sample: Sample) -> SampleOutcome | None:
    """The sample's outcome (:func:`datagen.outcomes.sample_outcome`) with its ``index``, for
    the live status; None for a sample without one."""
    outcome = outcomes.sample_outcome(sample.metadata)
    return cast(SampleOutcome, {"index": sample.index, **outcome}) if outcome is not None else None


def thumbnail(sample: Sample, width: int = PREVIEW_WIDTH) -> np.ndarray | None:
    """BGR thumbnail ``width`` pixels wide (module doc); None if the sample has no picture.
    Drawn at thumbnail size (the images are scaled down first): ~10 ms of CPU for 640x480, mostly
    decoding the PNGs."""
    wanted = {"rgb.png": "rgb", "seg.png": "seg", "map.png": "map"}
    item = {
        field: _decoded(sample.parts[name], name)
        for name, field in wanted.items()
        if name in sample.parts
    }
    meta = sample.metadata if "json" in sample.parts else None
    # cv2.imdecode gives the stored RGB PNGs in BGR order, which is what cv2.imencode expects
    if "map" in item:
        return _scaled(item["map"], width)
    if "rgb" not in item:
        return None
    image = _scaled(item["rgb"], width)
    instances = labelled_views(meta)[0].instances if meta is not None else []
    if "seg" not in item or not instances:
        return image
    scale = image.shape[1] / item["rgb"].shape[1]
    seg = cv2.resize(item["seg"], image.shape[1::-1], interpolation=cv2.INTER_NEAREST)
    overlay = image.copy()
    for obj in instances:
        overlay[seg == obj["instance_id"]] = _colour(obj["instance_id"])
    image = cv2.addWeighted(overlay, 0.45, image, 0.55, 0)
    for obj in instances:
        x0, y0, x1, y1 = (round(v * scale) for v in obj["bbox_xyxy"])
        cv2.rectangle(image, (x0, y0), (x1, y1), (255, 255, 255), 1)
    return image


def _decoded(png: bytes, name: str) -> np.ndarray:
    """In this thread (the loader's pool would compete with the other workers for the cores),
    bounded as every picture datagen reads (``ImageInputError``, a ValueError, naming the part)."""
    image = decode_image(png, what=f"part {name}")
    return image[..., :3] if image.ndim == 3 else image


def _scaled(image: np.ndarray, width: int) -> np.ndarray:
    scale = width / image.shape[1]
    size = (width, max(1, round(image.shape[0] * scale)))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_NEAREST)


def _colour(instance_id: int) -> tuple[int, int, int]:
    """A stable BGR colour per instance id (golden-ratio hue steps)."""
    hue = int((instance_id * 0.618033988749895 % 1.0) * 179)
    b, g, r = cv2.cvtColor(np.array([[[hue, 200, 255]]], np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return int(b), int(g), int(r)


class PreviewFeed:
    """A worker's previews: ``offer(sample)`` after each publish; sends one if
    its time has come (module doc). Its own connection (QoS 0, no session); if the broker
    cannot be reached, or ``$DATAGEN_LIVE=0``, it does nothing."""

    def __init__(self, broker_url: str, build_id: str, worker: str):
        self.topic = topics(build_id).live_preview(worker)
        self.next_at = 0.0  # time.monotonic() of the next preview
        self.conn: MqttConnection | None = None
        if not live_enabled():
            return
        try:
            self.conn = MqttConnection(
                broker_url, client_id(build_id, f"preview-{worker}"), timeout_s=5.0
            )
        except MqttConnectError as exc:
            log.warning("no previews from worker %s (%s)", worker, exc)

    def offer(self, sample: Sample) -> None:
        start = time.monotonic()
        if self.conn is None or start < self.next_at:
            return
        cpu = time.thread_time()  # its CPU time: waiting for a busy core costs the build nothing
        jpeg = None
        try:
            image = thumbnail(sample)
            if image is not None:
                ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
                jpeg = encoded.tobytes() if ok else None
        except Exception as exc:  # a preview must never fail a sample
            log.warning("no preview of sample %d: %s", sample.index, exc)
        if jpeg is not None:
            self.conn.publish(self.topic, jpeg, qos=0)
        spent = time.thread_time() - cpu
        self.next_at = start + max(PREVIEW_PERIOD_S, spent / PREVIEW_BUDGET)

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None
