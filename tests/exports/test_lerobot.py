"""The LeRobot v3.0 export (docs/export-lerobot.md), written from a filmed grasp campaign (by the
real command line) and from navigation episodes (one episode a file, by small file limits), read
back by lerobot 0.4.4 itself in the readers' environment (the page's snippet, then the frames it
decodes) and checked against the dataset's own records and PNGs."""

from __future__ import annotations

import itertools
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import export_copy  # tests/conftest.py: copy a session dataset, export it

import datagen
from datagen.exports import lerobot, lerobot_meta
from datagen.exports.episodes import episodes, frames_of
from datagen.exports.runner import run_exports

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "export-lerobot.md"
PSNR_BOUND_DB = 29.0  # the page's bound: every decoded frame at least this close to its PNG
AERIAL_PSNR_BOUND_DB = 27.0  # the page's bound for aerial episodes' views
# run after the page's snippet (which leaves `ds`): what lerobot read, as JSON on the last line
# and the decoded images as .npy files in the folder sys.argv[1]
CHECKS = r"""
import json, sys
from pathlib import Path
import numpy as np
out = Path(sys.argv[1])
bounds = [[int(e["dataset_from_index"]), int(e["dataset_to_index"])] for e in ds.meta.episodes]
picks = sorted({i for a, b in bounds for i in (a, (a + b) // 2, b - 1)})
frames = {}
for i in picks:
    record = {}
    for key, value in ds[i].items():
        if key in ds.meta.camera_keys or key.startswith("observation.depth."):
            if key in ds.meta.camera_keys:
                value = (value.permute(1, 2, 0) * 255).round().to(dtype=__import__("torch").uint8)
            np.save(out / f"{i}-{key}.npy", value.numpy())
            record[key] = [list(value.shape), str(value.dtype)]
        else:
            record[key] = value if isinstance(value, str) else value.tolist()
    frames[i] = record
print(json.dumps({
    "episodes": ds.num_episodes, "frames": ds.num_frames, "fps": ds.fps,
    "robot_type": ds.meta.robot_type, "bounds": bounds,
    "features": {k: list(v["shape"]) for k, v in ds.features.items()},
    "tasks": [list(e["tasks"]) for e in ds.meta.episodes],
    "keys": [e["datagen/key"] for e in ds.meta.episodes],
    "stats": {k: {s: list(np.shape(v)) for s, v in st.items()} for k, st in ds.meta.stats.items()},
    "picked": frames,
}))
"""


def _snippet() -> str:
    text = DOC.read_text()
    found = re.findall(
        r"<!-- snippet: tested by tests/exports/test_lerobot.py -->\n```python\n(.*?)```",
        text,
        re.S,
    )
    assert len(found) == 1, "export-lerobot.md: one tested snippet"
    return found[0]


def _read(readers_python: Path, folder: Path) -> tuple[dict, Path]:
    """Runs the page's snippet and CHECKS in ``folder`` (which holds datasets/grasps/lerobot)."""
    out = folder / "read"
    out.mkdir()
    env = {
        **os.environ,
        "HF_HUB_OFFLINE": "1",
        "HF_DATASETS_OFFLINE": "1",
        "HF_HOME": str(folder / "hf"),
    }
    done = subprocess.run(
        [str(readers_python), "-c", _snippet() + CHECKS, str(out)],
        capture_output=True,
        text=True,
        cwd=folder,
        env=env,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.strip().splitlines()
    assert "episodes," in lines[0] and "frames at" in lines[0], done.stdout[:500]
    return json.loads(lines[-1]), out


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255**2 / mse)


def _check(
    read: dict, out: Path, root: Path, robot_type: str, psnr_bound: float = PSNR_BOUND_DB
) -> None:
    """What lerobot read equals the dataset's own records (datagen.load and its episodes)."""
    dataset = datagen.load(root)
    manifest = json.loads((root / "manifest.json").read_text())
    ours = list(episodes(dataset, manifest))
    lengths = [e.length for _, e in ours]
    starts = np.cumsum([0, *lengths])
    assert read["episodes"] == len(ours) and read["frames"] == sum(lengths)
    assert read["fps"] == round(ours[0][1].fps) and read["robot_type"] == robot_type
    assert read["bounds"] == [[int(a), int(b)] for a, b in itertools.pairwise(starts)]
    assert read["keys"] == [e.key for _, e in ours]
    assert read["tasks"] == [[e.task] for _, e in ours]
    first = ours[0][1]
    assert read["features"]["observation.state"] == [first.state.shape[1]]
    assert read["features"]["action"] == [first.action.shape[1]]
    for camera in first.cameras:
        assert read["stats"][f"observation.images.{camera}"]["mean"] == [3, 1, 1]
    info = json.loads((root / "lerobot" / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0"
    assert info["features"]["observation.state"]["names"] == first.state_names
    stats = json.loads((root / "lerobot" / "meta" / "stats.json").read_text())
    states = np.concatenate([e.state for _, e in ours]).astype(np.float64)
    assert np.allclose(stats["observation.state"]["mean"], states.mean(0))
    assert np.allclose(stats["observation.state"]["min"], states.min(0))
    for index, record in read["picked"].items():
        index = int(index)
        n = int(np.searchsorted(starts, index, side="right")) - 1
        position, episode = ours[n]
        t = index - starts[n]
        assert record["episode_index"] == n and record["frame_index"] == t
        assert record["timestamp"] == pytest.approx(t / episode.fps, abs=1e-6)
        assert record["task"] == episode.task
        assert np.array_equal(np.float32(record["observation.state"]), episode.state[t])
        assert np.array_equal(np.float32(record["action"]), episode.action[t])
        last = t == episode.length - 1
        assert record["next.done"] == last and record["next.reward"] == float(
            last and episode.success
        )
        assert record["next.success"] == (last and episode.success)
        raw = dataset.raw(position, episode.parts())
        for camera, parts in episode.cameras.items():
            decoded = np.load(out / f"{index}-observation.images.{camera}.npy")
            source = frames_of(raw, [parts[t]])[0]
            assert decoded.shape == source.shape
            assert _psnr(decoded, source) >= psnr_bound, (index, camera)
        for camera, parts in episode.depth.items():
            decoded = np.load(out / f"{index}-observation.depth.{camera}.npy")
            assert np.array_equal(decoded, frames_of(raw, [parts[t]])[0])  # lossless, mm


@pytest.mark.sim
@pytest.mark.slow
def test_campaign_export_is_read_by_lerobot(campaign_dataset, readers_python, tmp_path):
    root = tmp_path / "datasets" / "grasps"
    done = export_copy(campaign_dataset, root, "lerobot")
    assert done.returncode == 0, done.stderr[-2000:]
    manifest = json.loads((root / "manifest.json").read_text())
    assert manifest["exports"]["lerobot"]["path"] == "lerobot"
    read, out = _read(readers_python, tmp_path)
    assert read["features"]["observation.images.wrist"] == [96, 128, 3]
    _check(read, out, root, robot_type="panda")


@pytest.mark.sim
@pytest.mark.slow
def test_navigation_export_over_many_files_is_read_by_lerobot(
    navigation_dataset, readers_python, tmp_path, monkeypatch
):
    root = tmp_path / "datasets" / "grasps"
    shutil.copytree(navigation_dataset, root)
    monkeypatch.setattr(lerobot, "MB", 0)  # file size limits of 0: a new file for each episode
    run_exports(root, ["lerobot"])
    files = sorted(
        p.relative_to(root / "lerobot").as_posix() for p in (root / "lerobot").rglob("file-*")
    )
    assert files == [
        "data/chunk-000/file-000.parquet",
        "data/chunk-000/file-001.parquet",
        "meta/episodes/chunk-000/file-000.parquet",
        "videos/observation.images.head/chunk-000/file-000.mp4",
        "videos/observation.images.head/chunk-000/file-001.mp4",
    ]
    read, out = _read(readers_python, tmp_path)
    assert read["features"]["observation.depth.head"] == [72, 96]
    _check(read, out, root, robot_type="fetch")


@pytest.mark.sim
@pytest.mark.slow
def test_aerial_export_is_read_by_lerobot_one_episode_per_drone(
    aerial_dataset, readers_python, tmp_path
):
    root = tmp_path / "datasets" / "grasps"  # where the page's snippet reads
    shutil.copytree(aerial_dataset, root)
    run_exports(root, ["lerobot"])
    read, out = _read(readers_python, tmp_path)
    assert read["features"]["observation.depth.down"] == [72, 96]
    assert read["episodes"] == 4  # two episodes of two drones
    info = json.loads((root / "lerobot" / "meta" / "info.json").read_text())
    left_out = info["datagen"]["left_out"]  # what the export says it leaves out
    assert {"f<k>.d0.flow.png", "f<k>.d0.seg.png", "map.png", "occupancy.npz"} <= set(left_out)
    assert not {"f<k>.d0.rgb.png", "f<k>.d0_down.depth.png", "json"} & set(left_out)
    # a downward view is a textured floor filling the frame: yuv420p's halved colour loses more
    _check(read, out, root, robot_type="quadrotor", psnr_bound=AERIAL_PSNR_BOUND_DB)


@pytest.mark.sim
def test_frames_dataset_is_refused_in_one_line(frames_dataset, tmp_path):
    root = tmp_path / "frames"
    done = export_copy(frames_dataset, root, "lerobot")
    assert done.returncode != 0
    assert len(done.stderr.strip().splitlines()) == 1 and "episodes" in done.stderr
    assert not (root / "lerobot").exists()


def test_histogram_stats_are_exact():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (7, 9, 3), dtype=np.uint8)
    stats = lerobot_meta.histogram_stats(lerobot_meta.rgb_histogram(image), 1 / 255, 1, (3, 1, 1))
    pixels = image.reshape(-1, 3) / 255
    assert np.allclose(stats["mean"].ravel(), pixels.mean(0))
    assert np.allclose(stats["std"].ravel(), pixels.std(0))
    assert np.allclose(stats["min"].ravel(), pixels.min(0))
    assert np.allclose(stats["max"].ravel(), pixels.max(0))
    assert np.allclose(
        stats["q50"].ravel(), np.quantile(pixels, 0.5, axis=0, method="inverted_cdf")
    )
