"""The tables and metadata of the LeRobot export, as LeRobot 0.4's own writer lays them out:
``meta/info.json`` (features), ``meta/stats.json``, ``meta/tasks.parquet``, the per-episode rows
of ``meta/episodes/`` and the frame rows of ``data/``, each parquet file series rolled over at its
size limit (docs/export-lerobot.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from datagen.exports.checks import strict_json
from datagen.exports.files import inside
from datagen.exports.lerobot_video import next_file

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000  # files per chunk folder
DATA_FILE_MB = 100
VIDEO_FILE_MB = 200
QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}
DEFAULT_FEATURES = {  # every frame's indices, last in the features as LeRobot puts them
    "timestamp": "float32",
    "frame_index": "int64",
    "episode_index": "int64",
    "index": "int64",
    "task_index": "int64",
}
_ARROW = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_(), "uint16": pa.uint16()}


def _hf_feature(ft: dict) -> dict:
    """The feature as the ``datasets`` library writes it in a parquet file's metadata."""
    if len(ft["shape"]) == 2:
        return {"shape": list(ft["shape"]), "dtype": ft["dtype"], "_type": "Array2D"}
    value = {"dtype": ft["dtype"], "_type": "Value"}
    return (
        value
        if ft["shape"] == [1]
        else {"feature": value, "length": ft["shape"][0], "_type": "List"}
    )


def data_schema(features: dict[str, dict]) -> pa.Schema:
    """The data files' schema: a (1,) feature is a scalar column, a (k,) one a fixed-size list,
    an (H, W) one a list of lists; video features live in the MP4 files."""
    fields = []
    for key, ft in features.items():
        if ft["dtype"] == "video":
            continue
        kind = _ARROW[ft["dtype"]]
        if len(ft["shape"]) == 2:
            kind = pa.list_(pa.list_(kind))
        elif ft["shape"] != [1]:
            kind = pa.list_(kind, ft["shape"][0])
        fields.append(pa.field(key, kind))
    hf = {k: _hf_feature(ft) for k, ft in features.items() if ft["dtype"] != "video"}
    return pa.schema(
        fields, metadata={"huggingface": json.dumps({"info": {"features": hf}}, allow_nan=False)}
    )


def column(values: np.ndarray, kind: pa.DataType) -> pa.Array:
    """(T,) -> scalars, (T, k) -> fixed-size lists, (T, H, W) -> lists of lists."""
    flat = pa.array(np.ascontiguousarray(values).reshape(-1))
    if values.ndim == 1:
        return flat
    if values.ndim == 2:
        return pa.FixedSizeListArray.from_arrays(flat, values.shape[1])
    t, h, w = values.shape
    rows = pa.ListArray.from_arrays(pa.array(np.arange(0, t * h * w + 1, w, dtype=np.int32)), flat)
    return pa.ListArray.from_arrays(
        pa.array(np.arange(0, t * h + 1, h, dtype=np.int32)), rows
    ).cast(kind)


class ParquetFiles:
    """A series ``<folder>/chunk-XXX/file-YYY.parquet`` of one schema, a row group per write;
    the next file begins once the open one holds ``limit_bytes`` (or its schema is unknown yet:
    ``schema`` None takes the first table's)."""

    def __init__(self, root: Path, folder: str, schema: pa.Schema | None, limit_bytes: int):
        self.root, self.folder, self.schema, self.limit_bytes = root, folder, schema, limit_bytes
        self.chunk, self.file = 0, -1
        self.sink: Any = None  # pyarrow's file and writer, while a file is open
        self.writer: Any = None
        self.written: list[Path] = []

    def position(self) -> tuple[int, int]:
        """The (chunk, file) numbers the next write goes to: a new file once the open one is full."""
        if self.writer is None or self.sink.tell() >= self.limit_bytes:
            self.close()
            self.chunk, self.file = (
                (0, 0) if self.file < 0 else next_file(self.chunk, self.file, CHUNKS_SIZE)
            )
            folder = inside(self.root, *self.folder.split("/"), f"chunk-{self.chunk:03d}")
            folder.mkdir(parents=True, exist_ok=True)
            path = inside(folder, f"file-{self.file:03d}.parquet")
            self.sink = pa.OSFile(str(path), "wb")
            self.writer = pq.ParquetWriter(self.sink, self.schema, compression="snappy")
            self.written.append(path)
        return self.chunk, self.file

    def write(self, table: pa.Table) -> None:
        """Writes ``table`` as one row group into the open file (the :meth:`position` asked
        last), or the first one."""
        if self.writer is None:
            self.position()
        self.writer.write_table(table.cast(self.schema))

    def close(self) -> list[Path]:
        if self.writer is not None:
            self.writer.close()
            self.sink.close()
            self.writer = self.sink = None
        return self.written


def numeric_stats(values: np.ndarray) -> dict[str, np.ndarray]:
    """Per-dimension stats of a (T, ...) feature over its T frames (min and max in its dtype)."""
    flat = values.reshape(len(values), -1) if values.ndim > 1 else values[:, None]
    as_float = flat.astype(np.float64)
    stats = {
        "min": flat.min(axis=0),
        "max": flat.max(axis=0),
        "mean": as_float.mean(axis=0),
        "std": as_float.std(axis=0),
        "count": np.array([len(values)]),
    }
    for name, q in QUANTILES.items():
        stats[name] = np.quantile(as_float, q, axis=0)
    return stats


def aggregate(total: dict[str, np.ndarray] | None, new: dict[str, np.ndarray]) -> dict:
    """Two stats merged as LeRobot's aggregate_stats merges episodes: exact min, max, mean and
    std; quantiles as count-weighted means."""
    if total is None:
        return new
    n1, n2 = total["count"][0], new["count"][0]
    n = n1 + n2
    mean = (total["mean"] * n1 + new["mean"] * n2) / n
    var = (
        n1 * (total["std"] ** 2 + (total["mean"] - mean) ** 2)
        + n2 * (new["std"] ** 2 + (new["mean"] - mean) ** 2)
    ) / n
    merged = {
        "min": np.minimum(total["min"], new["min"]),
        "max": np.maximum(total["max"], new["max"]),
        "mean": mean,
        "std": np.sqrt(var),
        "count": np.array([n]),
    }
    for name in QUANTILES:
        merged[name] = (total[name] * n1 + new[name] * n2) / n
    return merged


def histogram_stats(hist: np.ndarray, scale: float, frames: int, shape: tuple) -> dict:
    """Stats of the values counted in ``hist`` (channels x bins: value v counted at bin v),
    scaled by ``scale``, exact quantiles, each stat of ``shape`` (images: (3, 1, 1)); ``count``
    is the number of frames, as LeRobot counts images."""
    values = np.arange(hist.shape[1], dtype=np.float64) * scale
    n = hist.sum(axis=1)
    mean = hist @ values / n
    std = np.sqrt(np.maximum(hist @ values**2 / n - mean**2, 0))
    cum = np.cumsum(hist, axis=1)
    present = hist > 0
    stats = {
        "min": values[present.argmax(axis=1)],
        "max": values[hist.shape[1] - 1 - present[:, ::-1].argmax(axis=1)],
        "mean": mean,
        "std": std,
    }
    for name, q in QUANTILES.items():
        stats[name] = values[(cum < (q * n)[:, None]).sum(axis=1)]
    stats = {k: v.reshape(shape) for k, v in stats.items()}
    return stats | {"count": np.array([frames])}


def rgb_histogram(image: np.ndarray) -> np.ndarray:
    """(3, 256) counts of each channel's values in an (H, W, 3) uint8 image."""
    return np.stack([np.bincount(image[..., c].reshape(-1), minlength=256) for c in range(3)])


def stats_columns(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, Any]:
    """The ``stats/<feature>/<stat>`` columns of an episode's row in meta/episodes."""
    return {
        f"stats/{key}/{name}": value.tolist()
        for key, s in stats.items()
        for name, value in s.items()
    }


def write_tasks(out: Path, tasks: dict[str, int]) -> Path:
    """meta/tasks.parquet as pandas writes LeRobot's table: the task strings are its index."""
    pandas_meta = {
        "index_columns": ["__index_level_0__"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": None,
                "field_name": "__index_level_0__",
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": None,
            },
        ],
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
    }
    schema = pa.schema(
        [("task_index", pa.int64()), ("__index_level_0__", pa.string())],
        metadata={"pandas": json.dumps(pandas_meta, allow_nan=False)},
    )
    table = pa.table([list(tasks.values()), list(tasks)], schema=schema)
    path = inside(out, "meta", "tasks.parquet")
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)
    return path


def write_json(path: Path, data: dict) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(strict_json(data, path.name, indent=4, ensure_ascii=False) + "\n")
    return path


def info(features: dict, fps: int, robot_type: str, episodes: int, frames: int, tasks: int) -> dict:
    """meta/info.json."""
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": episodes,
        "total_frames": frames,
        "total_tasks": tasks,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": VIDEO_FILE_MB,
        "fps": fps,
        "splits": {"train": f"0:{episodes}"},
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "video_path": "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4",
        "features": features,
    }
