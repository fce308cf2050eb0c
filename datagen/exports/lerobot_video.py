"""The camera streams of the LeRobot export: one MP4 file series per camera key, many episodes
per file, each frame encoded as it is read (H.264, see docs/export-lerobot.md for the choice).

Frame n of a file is at exactly ``n / fps`` seconds: an episode's frames follow the previous
episode's in the same file, so its ``from_timestamp`` is the number of frames before it over
fps, which is what LeRobot adds to a frame's ``timestamp`` to find it in the file. A file is
closed, and the next begun, once its encoded frames hold ``limit_bytes``; after ``chunks_size`` files the chunk
number goes up, as LeRobot's own writer does.
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np

from datagen.dataset.manifest import DatasetError
from datagen.exports.files import inside

CODEC = "libx264"  # H.264: decoded by PyAV/torchvision, torchcodec, browsers and the HF viewer
CODEC_NAME = "h264"  # as PyAV's codec.canonical_name reads it back
PIX_FMT = "yuv420p"
CRF = 18  # measured on 128x96 renders: PSNR >= 29.9 dB a frame, 33.2 dB mean (docs)
GOP = 2  # a key frame every 2 frames, as LeRobot encodes: a frame decodes from at most 2
PRESET = "medium"


def next_file(chunk: int, file: int, chunks_size: int) -> tuple[int, int]:
    """The (chunk, file) numbers after ``(chunk, file)``: LeRobot's update_chunk_file_indices."""
    return (chunk + 1, 0) if file == chunks_size - 1 else (chunk, file + 1)


def video_info(height: int, width: int, fps: int) -> dict:
    """The ``info`` of a video feature in meta/info.json, as LeRobot's get_video_info reads it."""
    return {
        "video.height": height,
        "video.width": width,
        "video.codec": CODEC_NAME,
        "video.pix_fmt": PIX_FMT,
        "video.is_depth_map": False,
        "video.fps": fps,
        "video.channels": 3,
        "has_audio": False,
    }


class VideoFiles:
    """The MP4 files of one camera key under ``root/videos/<key>/chunk-XXX/file-YYY.mp4``."""

    def __init__(self, root: Path, key: str, fps: int, limit_bytes: int, chunks_size: int):
        self.root, self.key, self.fps = root, key, fps
        self.limit_bytes, self.chunks_size = limit_bytes, chunks_size
        self.chunk, self.file = 0, -1
        self.path: Path | None = None
        self.container: Any = None  # av's output container and stream, while a file is open
        self.stream: Any = None
        self.frames = self.bytes = 0  # frames and encoded bytes in the open file
        self.shape: tuple[int, int] | None = None  # (height, width)
        self.written: list[Path] = []

    def _open(self) -> None:
        if self.file < 0:
            self.file = 0
        else:
            self.chunk, self.file = next_file(self.chunk, self.file, self.chunks_size)
        folder = inside(self.root, "videos", self.key, f"chunk-{self.chunk:03d}")
        folder.mkdir(parents=True, exist_ok=True)
        self.path = inside(folder, f"file-{self.file:03d}.mp4")
        self.container = av.open(
            str(self.path), "w", format="mp4", options={"movflags": "faststart"}
        )
        options = {"crf": str(CRF), "g": str(GOP), "preset": PRESET}
        self.stream = self.container.add_stream(CODEC, rate=self.fps, options=options)
        assert self.shape is not None  # known before the first file opens
        self.stream.height, self.stream.width = self.shape
        self.stream.pix_fmt = PIX_FMT
        self.stream.codec_context.time_base = Fraction(1, self.fps)
        self.frames = self.bytes = 0
        self.written.append(self.path)

    def _close(self) -> None:
        if self.container is not None:
            for packet in self.stream.encode(None):  # flush the encoder
                self.container.mux(packet)
            self.container.close()
            self.container = self.stream = None

    def add_episode(self, frames: Iterable[np.ndarray]) -> dict[str, float | int]:
        """Encodes an episode's (H, W, 3) uint8 RGB frames after the open file's; returns the
        episode's ``videos/<key>/...`` columns of meta/episodes."""
        frames = iter(frames)
        first = next(frames)
        height, width = first.shape[:2]
        if self.shape is None:
            if height % 2 or width % 2:
                raise DatasetError(
                    f"camera {self.key}: {width}x{height} images cannot be stored as {PIX_FMT} "
                    f"video: build with an even render.width and render.height"
                )
            self.shape = (height, width)
        if self.container is None or self.bytes >= self.limit_bytes:
            self._close()
            self._open()
        start = self.frames
        for image in itertools.chain([first], frames):
            if image.shape[:2] != self.shape:
                raise DatasetError(
                    f"camera {self.key}: a {image.shape[1]}x{image.shape[0]} frame among "
                    f"{self.shape[1]}x{self.shape[0]} ones"
                )
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            frame.pts, frame.time_base = self.frames, Fraction(1, self.fps)
            for packet in self.stream.encode(frame):
                self.bytes += packet.size
                self.container.mux(packet)
            self.frames += 1
        prefix = f"videos/{self.key}/"
        return {
            prefix + "chunk_index": self.chunk,
            prefix + "file_index": self.file,
            prefix + "from_timestamp": start / self.fps,
            prefix + "to_timestamp": self.frames / self.fps,
        }

    def close(self) -> list[Path]:
        self._close()
        return self.written

    def abort(self) -> None:
        """Closes the open file after a failure, whatever its state, ignoring what that raises:
        left open, PyAV's finaliser would write its trailer later, once the export's folder is
        removed, and print a traceback after the export's one-line error."""
        container, self.container, self.stream = self.container, None, None
        if container is not None:
            with contextlib.suppress(Exception):  # the failure itself (a full disk) is reported
                container.close()
