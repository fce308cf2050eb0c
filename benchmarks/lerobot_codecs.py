"""Which video codec the LeRobot export uses: size, encoding time and PSNR of the decoded frames
against the stored PNGs, for H.264 (the export's choice, CRF 18 and 23) and AV1 (lerobot's
default, libsvtav1 CRF 30), all yuv420p with a key frame every 2 frames, in one run.

    .venv/bin/python benchmarks/lerobot_codecs.py        # builds the two datasets below (~1 min)
    .venv/bin/python benchmarks/lerobot_codecs.py DIR ...   # or any datasets of episodes

By default it builds, with the command line, what the export tests read (tests/conftest.py): 3
grasp attempts filmed at 10 Hz at 128x96 from the workspace and wrist cameras (seed 5), and 2
corridor episodes at 96x72, 2 Hz (seed 3); every camera stream of every episode is encoded as
one clip per codec, decoded with PyAV, and compared frame by frame.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
CODECS = (  # (codec, options)
    ("libx264", {"crf": "18", "g": "2", "preset": "medium"}),
    ("libx264", {"crf": "23", "g": "2", "preset": "medium"}),
    ("libsvtav1", {"crf": "30", "g": "2", "preset": "12"}),
)
BUILDS = {
    "grasps": (["campaign", "grasp"], {
        "version": 1, "scene": "grasp_attempts", "num_samples": 3, "seed": 5,
        "render": {"width": 128, "height": 96, "wrist_camera": True},
        "campaign": {"hold_time": 0.3, "post_grasp_frame": False, "record_hz": 10, "frame_hz": 10},
    }),
    "corridor": (["build"], {
        "version": 1, "scene": "navigation", "num_samples": 2, "seed": 3,
        "render": {"width": 96, "height": 72, "far": 20.0},
        "navigation": {"family": "corridor", "frame_rate_hz": 2},
    }),
}  # fmt: skip


def _clips(root: Path) -> tuple[list[np.ndarray], float]:
    from datagen.dataset.loader import load
    from datagen.exports.episodes import episodes, frames_of

    dataset, manifest = load(root), json.loads((root / "manifest.json").read_text())
    clips, fps = [], 10.0
    for i, episode in episodes(dataset, manifest):
        raw = dataset.raw(i, episode.parts())
        clips += [frames_of(raw, parts) for parts in episode.cameras.values()]
        fps = episode.fps
    return clips, fps


def _encode(codec: str, options: dict, frames: np.ndarray, fps: float, path: Path) -> None:
    rate = Fraction(fps).limit_denominator(1000)
    with av.open(str(path), "w", format="mp4") as container:
        stream = container.add_stream(codec, rate=rate, options=options)
        stream.height, stream.width = frames.shape[1:3]
        stream.pix_fmt = "yuv420p"
        for n, image in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(image, format="rgb24")
            frame.pts, frame.time_base = n, 1 / rate
            container.mux(stream.encode(frame))
        container.mux(stream.encode(None))


def _decode(path: Path) -> np.ndarray:
    with av.open(str(path)) as container:
        return np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b) ** 2)
    return float(10 * np.log10(255**2 / max(mse, 1e-12)))


def _build(tmp: Path) -> list[Path]:
    roots = []
    for name, (command, config) in BUILDS.items():
        path, out = tmp / f"{name}.yaml", tmp / name
        path.write_text(yaml.safe_dump(config))
        quiet = ["--no-preview"] if command[0] == "build" else []  # a campaign draws none
        done = subprocess.run(
            [sys.executable, "-m", "datagen.cli", *command, str(path), "--out", str(out),
             "--workers", "1", *quiet],
            cwd=REPO, capture_output=True, text=True,
        )  # fmt: skip
        if done.returncode != 0:
            raise SystemExit(f"building {name} failed:\n{done.stderr[-3000:]}")
        roots.append(out)
    return roots


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="*", type=Path, help="datasets of episodes")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="datagen-codecs-") as tmp:
        roots = args.datasets or _build(Path(tmp))
        for root in roots:
            clips, fps = _clips(root)
            height, width = clips[0].shape[1:3]
            frames = sum(len(c) for c in clips)
            for codec, options in CODECS:
                size, psnrs, start = 0, [], time.perf_counter()
                for k, clip in enumerate(clips):
                    path = Path(tmp) / f"{codec}-{options['crf']}-{k}.mp4"
                    _encode(codec, options, clip, fps, path)
                    size += path.stat().st_size
                seconds = time.perf_counter() - start
                for k, clip in enumerate(clips):
                    decoded = _decode(Path(tmp) / f"{codec}-{options['crf']}-{k}.mp4")
                    psnrs += [_psnr(a, b) for a, b in zip(clip, decoded, strict=True)]
                print(
                    f"{root.name}: {frames} frames {width}x{height}, {codec} crf {options['crf']}: "
                    f"{size / frames / 1024:.2f} KiB/frame, encode {1000 * seconds / frames:.2f} "
                    f"ms/frame, PSNR min {min(psnrs):.1f} mean {np.mean(psnrs):.1f} dB",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
