"""LeRobot dataset v3.0: ``DIR/lerobot``, loadable with ``LeRobotDataset(repo_id, root=DIR/lerobot)``
(lerobot 0.4), written here with pyarrow and PyAV (datagen never imports lerobot).

One LeRobot episode per :class:`datagen.exports.episodes.Episode`, in the dataset's order: its
frames are rows of ``data/`` (``observation.state``, ``action``, ``next.reward``, ``next.done``,
``next.success``, the episode's extras as ``observation.<name>``, depth as ``observation.depth.
<camera>`` (H, W) uint16 mm, and LeRobot's indices), its cameras the H.264 streams
``observation.images.<camera>`` in ``videos/``, its task a row of ``meta/tasks.parquet``, and its
boundaries and stats a row of ``meta/episodes/``. Samples are read one at a time and their frames
encoded as they are decoded. The mapping and its reasons: docs/export-lerobot.md.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from datagen.dataset.manifest import DatasetError
from datagen.dataset.parts import decode_parts
from datagen.exports import lerobot_meta as meta
from datagen.exports.episodes import Episode, episodes_of, frames_of
from datagen.exports.files import inside
from datagen.exports.left_out import LeftOut
from datagen.exports.lerobot_robots import (
    UNITS,
    LeRobotArm,
    calibration,
    in_lerobot_units,
    lerobot_arm,
)
from datagen.exports.lerobot_video import VideoFiles, video_info
from datagen.records import ExportedDataset, Manifest, SampleProgress

MB = 1024**2
EPISODE_ROWS_PER_GROUP = 100  # meta/episodes rows buffered before a row group is written
# the robot of each kind of episode but grasps (whose arm is the config's)
ROBOT_OF_KIND = {"navigation": "fetch"}


def export(
    dataset: ExportedDataset,
    manifest: Manifest,
    out: Path,
    on_progress: SampleProgress | None = None,
    robot: str | None = None,
    units: str | None = None,
) -> list[Path]:
    """Writes ``out``; ``robot``: a lerobot arm (``lerobot_robots.ARMS``) whose motor names,
    order and units the states and actions take, in ``units`` (its default if None)."""
    out.mkdir()
    writer: _Writer | None = None
    total = len(dataset)
    try:
        for i in range(total):
            held = episodes_of(dataset, manifest, i)
            for episode in held:
                raw = dataset.raw(i, episode.parts())
                if writer is None:
                    arm = _arm(robot, units, manifest, episode)
                    writer = _Writer(out, manifest, _in_units(episode, arm, units), raw)
                    writer.robot(arm, units)
                writer.add(_in_units(episode, writer.arm, writer.units), raw)
            if writer is not None and held:
                written = {"json", "trajectory.npz"}.union(*(e.parts() for e in held))
                writer.left_out.add(dataset.part_names(i), written)
            if on_progress:
                on_progress(i + 1, total)
        if writer is None:
            raise DatasetError(
                f"cannot export 'lerobot': none of the {total} samples holds an episode (a grasp "
                f"attempt that found no candidate holds none)"
            )
        return writer.finish()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise


def _arm(
    robot: str | None, units: str | None, manifest: Manifest, episode: Episode
) -> LeRobotArm | None:
    if robot is None:
        return None
    if units is not None and units not in UNITS:
        raise DatasetError(f"unknown lerobot units {units!r}; expected one of {list(UNITS)}")
    name = manifest.get("config", {}).get("robot", {}).get("name")
    return lerobot_arm(robot, name, episode.kind)


def _in_units(episode: Episode, arm: LeRobotArm | None, units: str | None) -> Episode:
    return in_lerobot_units(episode, arm, units or arm.units) if arm else episode


def _fps(episode: Episode) -> int:
    fps = round(episode.fps)
    if fps < 1 or abs(episode.fps - fps) > 1e-6:
        raise DatasetError(
            f"sample {episode.key}: LeRobot needs a whole number of frames per second, and this "
            f"episode's frames come at {episode.fps:g} Hz: build with a whole frame rate"
        )
    return fps


def _features(episode: Episode, raw: dict[str, bytes], fps: int) -> dict[str, dict]:
    """meta/info.json's features, in the order LeRobot writes them."""

    def vector(dtype: str, names: list[str] | None, width: int = 1) -> dict:
        return {"dtype": dtype, "shape": [width], "names": names}

    features = {
        "observation.state": vector("float32", episode.state_names, episode.state.shape[1]),
        "action": vector("float32", episode.action_names, episode.action.shape[1]),
        "next.reward": vector("float32", None),
        "next.done": vector("bool", None),
        "next.success": vector("bool", None),
    }
    for name, values in episode.extras.items():
        features[f"observation.{name}"] = vector(
            str(values.dtype), episode.extra_names.get(name), values.shape[1]
        )
    for camera, parts in episode.cameras.items():
        height, width = decode_parts({"rgb.png": raw[parts[0]]})["rgb"].shape[:2]
        features[f"observation.images.{camera}"] = {
            "dtype": "video",
            "shape": [height, width, 3],
            "names": ["height", "width", "channels"],
            "info": video_info(height, width, fps),
        }
    for camera, parts in episode.depth.items():
        height, width = decode_parts({"depth.png": raw[parts[0]]})["depth"].shape[:2]
        features[f"observation.depth.{camera}"] = {
            "dtype": "uint16",
            "shape": [height, width],
            "names": ["height", "width"],
        }
    for key, dtype in meta.DEFAULT_FEATURES.items():
        features[key] = vector(dtype, None)
    return features


class _Writer:
    """The export's open files and running totals, set up from its first episode."""

    def __init__(self, out: Path, manifest: Manifest, first: Episode, raw: dict[str, bytes]):
        self.out, self.fps = out, _fps(first)
        self.features = _features(first, raw, self.fps)
        robot = manifest.get("config", {}).get("robot", {}).get("name")
        self.robot_type = (
            robot if first.kind == "grasp" else first.robot or ROBOT_OF_KIND[first.kind]
        )
        self.first = first
        self.data = meta.ParquetFiles(
            out, "data", meta.data_schema(self.features), meta.DATA_FILE_MB * MB
        )
        self.episode_files = meta.ParquetFiles(out, "meta/episodes", None, meta.DATA_FILE_MB * MB)
        self.videos = {
            camera: VideoFiles(
                out,
                f"observation.images.{camera}",
                self.fps,
                meta.VIDEO_FILE_MB * MB,
                meta.CHUNKS_SIZE,
            )
            for camera in first.cameras
        }
        self.tasks: dict[str, int] = {}
        self.rows: list[dict[str, Any]] = []
        self.stats: dict[str, dict[str, np.ndarray]] = {}
        self.episodes = self.frames = 0
        self.left_out = LeftOut()  # kinds of the exported samples' parts written nowhere
        self.arm: LeRobotArm | None = None
        self.units: str | None = None

    def robot(self, arm: LeRobotArm | None, units: str | None) -> None:
        """Writes the states and actions as lerobot's ``arm`` records them (None: datagen's)."""
        self.arm, self.units = arm, (units or arm.units) if arm else None
        if arm:
            self.robot_type = arm.robot_type

    def _check(self, episode: Episode) -> None:
        """Every episode must fill the first one's features."""
        first = self.first
        same = (
            _fps(episode) == self.fps
            and episode.state_names == first.state_names
            and episode.action_names == first.action_names
            and list(episode.cameras) == list(first.cameras)
            and list(episode.depth) == list(first.depth)
            and {k: v.shape[1:] for k, v in episode.extras.items()}
            == {k: v.shape[1:] for k, v in first.extras.items()}
        )
        if not same:
            raise DatasetError(
                f"sample {episode.key}: its episode's rate, state, action, cameras or extras "
                f"differ from those of sample {first.key}; a LeRobot dataset has one set of features"
            )

    def _frame_columns(self, episode: Episode, raw: dict[str, bytes]) -> dict[str, np.ndarray]:
        length = episode.length
        task = self.tasks.setdefault(episode.task, len(self.tasks))
        columns = {
            "observation.state": episode.state,
            "action": episode.action,
            "next.reward": episode.reward,
            "next.done": episode.done,
            "next.success": episode.done & episode.success,  # reached on the last frame
        }
        for name, values in episode.extras.items():
            columns[f"observation.{name}"] = values[:, 0] if values.shape[1] == 1 else values
        for camera, parts in episode.depth.items():
            columns[f"observation.depth.{camera}"] = frames_of(raw, parts)  # (T, H, W) uint16 mm
        columns |= {
            "timestamp": episode.timestamps,
            "frame_index": np.arange(length, dtype=np.int64),
            "episode_index": np.full(length, self.episodes, np.int64),
            "index": np.arange(self.frames, self.frames + length, dtype=np.int64),
            "task_index": np.full(length, task, np.int64),
        }
        return columns

    @staticmethod
    def _images(parts: list[str], raw: dict[str, bytes], hist: np.ndarray):
        """Each frame's image decoded as the encoder asks for it, counted into ``hist``."""
        for part in parts:
            image = decode_parts({"rgb.png": raw[part]})["rgb"]
            hist += meta.rgb_histogram(image)
            yield image

    def add(self, episode: Episode, raw: dict[str, bytes]) -> None:
        self._check(episode)
        columns = self._frame_columns(episode, raw)
        stats = {}
        for key, values in columns.items():
            if key.startswith("observation.depth."):
                hist = np.bincount(values.reshape(-1), minlength=2**16)[None]
                stats[key] = meta.histogram_stats(hist, 1.0, len(values), (1,))
            else:
                stats[key] = meta.numeric_stats(values)
        schema = self.data.schema
        assert schema is not None  # set when the dataset's features were known
        table = pa.table([meta.column(columns[f.name], f.type) for f in schema], schema=schema)
        chunk, file = self.data.position()
        self.data.write(table)
        row: dict[str, Any] = {
            "episode_index": self.episodes,
            "tasks": [episode.task],
            "length": episode.length,
            "data/chunk_index": chunk,
            "data/file_index": file,
            "dataset_from_index": self.frames,
            "dataset_to_index": self.frames + episode.length,
        }
        for camera, parts in episode.cameras.items():
            hist = np.zeros((3, 256), np.int64)
            row |= self.videos[camera].add_episode(self._images(parts, raw, hist))
            stats[f"observation.images.{camera}"] = meta.histogram_stats(
                hist, 1 / 255, episode.length, (3, 1, 1)
            )
        stats = {key: stats[key] for key in self.features}  # LeRobot's order
        row |= meta.stats_columns(stats)
        row |= {"datagen/key": episode.key, "datagen/success": episode.success}
        self.rows.append(row)
        for key, s in stats.items():
            self.stats[key] = meta.aggregate(self.stats.get(key), s)
        self.episodes += 1
        self.frames += episode.length
        if len(self.rows) >= EPISODE_ROWS_PER_GROUP:
            self._flush_rows()

    def _flush_rows(self) -> None:
        if not self.rows:
            return
        table = pa.Table.from_pylist(self.rows)
        files = self.episode_files
        if files.schema is None:
            files.schema = table.schema.append(pa.field("meta/episodes/chunk_index", pa.int64()))
            files.schema = files.schema.append(pa.field("meta/episodes/file_index", pa.int64()))
        chunk, file = files.position()
        n = len(self.rows)
        table = table.append_column("meta/episodes/chunk_index", pa.array([chunk] * n, pa.int64()))
        table = table.append_column("meta/episodes/file_index", pa.array([file] * n, pa.int64()))
        files.write(table)
        self.rows = []

    def abort(self) -> None:
        """Every file left open by a failure closed now, before the runner removes the folder."""
        for video in self.videos.values():
            video.abort()
        for files in (self.data, self.episode_files):
            with contextlib.suppress(Exception):  # the failure itself is what is reported
                files.close()

    def finish(self) -> list[Path]:
        self._flush_rows()
        written = [*self.data.close(), *self.episode_files.close()]
        for video in self.videos.values():
            written += video.close()
        written.append(meta.write_tasks(self.out, self.tasks))
        stats = {key: {k: v.tolist() for k, v in s.items()} for key, s in self.stats.items()}
        written.append(meta.write_json(inside(self.out, "meta", "stats.json"), stats))
        info = meta.info(
            self.features, self.fps, self.robot_type, self.episodes, self.frames, len(self.tasks)
        )
        info["datagen"] = {"left_out": self.left_out.kinds()}
        if self.arm and self.units:
            info["datagen"] |= {
                "lerobot_robot": self.arm.name,
                "units": self.units,
                "calibration": calibration(self.arm, self.units),
            }
        written.append(meta.write_json(inside(self.out, "meta", "info.json"), info))
        return written
