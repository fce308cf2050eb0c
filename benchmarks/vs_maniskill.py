"""datagen against ManiSkill's own recording path, side by side in one run.

    .venv/bin/python benchmarks/vs_maniskill.py                 # 120 frames each, 640x480
    .venv/bin/python benchmarks/vs_maniskill.py --frames 40     # quick

- **ManiSkill**: ``PickCube-v1`` (a Panda before a cube on a table: ManiSkill's comparable
  tabletop scene) with ``obs_mode="rgb+depth+segmentation"``, its sensor camera set to the same
  resolution, CPU physics and rendering, wrapped in ``RecordEpisode(save_trajectory=True,
  save_video=False)`` so every observation is written to its HDF5 trajectory file. Random actions;
  one frame per env step; a reset (new episode) every 50 steps, as a dataset recorder would.
  Timed from the first reset to ``env.close()`` (which flushes the file); ``gym.make`` is not.
  A second ManiSkill side rebuilds the scene every 2 frames (``reset(options={"reconfigure":
  True})`` and one step: RecordEpisode saves no episode without a step), closer to what datagen
  does (a freshly randomised, settled scene for every frame) and still in ManiSkill's favour.
- **datagen**: ``run_build`` of the default grasping config at the same resolution, the same
  number of frames, with W workers, once with one view per scene and once with ``--views``
  (default 4, ``render.views``: each settled scene rendered from that many randomised cameras,
  every view a fully annotated frame). Each scene is freshly randomised and settled by physics,
  annotated with boxes, 3D boxes, poses and visibility, published through Mosquitto and written
  by the writer process. Timed as a user sees it (start-up included).

The ratio is datagen frames/s ÷ ManiSkill frames/s (target 1.5).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def maniskill_fps(
    frames: int, width: int, height: int, episode_steps: int = 50, new_scene_per_frame: bool = False
) -> dict:
    import gymnasium as gym
    import mani_skill.envs  # noqa: F401 - registers the environments
    from mani_skill.utils.wrappers.record import RecordEpisode

    out = Path(tempfile.mkdtemp(prefix="datagen-maniskill-"))
    try:
        env = gym.make(
            "PickCube-v1",
            obs_mode="rgb+depth+segmentation",
            sim_backend="physx_cpu",
            render_backend="cpu",
            sensor_configs={"width": width, "height": height},
            max_episode_steps=episode_steps,
        )
        env = RecordEpisode(env, str(out), save_trajectory=True, save_video=False)
        start = time.monotonic()
        obs, _ = env.reset(seed=0)
        camera = next(iter(obs["sensor_data"].values()))
        shape = tuple(camera["rgb"].shape)
        for step in range(frames - 1):
            if new_scene_per_frame and step % 2:
                # a freshly built scene every 2 frames: its reset observation and one step
                # (RecordEpisode drops episodes without a step, so 1 frame per scene records nothing)
                env.reset(seed=step + 1, options={"reconfigure": True})
                continue
            obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if (step + 1) % episode_steps == 0 or bool(terminated) or bool(truncated):
                env.reset(seed=step + 1)
        env.close()
        seconds = time.monotonic() - start
        size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {"frames": frames, "seconds": round(seconds, 2), "frames_per_s": round(frames / seconds, 2),
            "rgb_shape": list(shape), "bytes": size}  # fmt: skip


def datagen_fps(frames: int, width: int, height: int, workers: int, views: int = 1) -> dict:
    import dataclasses

    from datagen.config import load_config
    from datagen.pipeline.run import run_build

    base = load_config(REPO / "configs/grasp_tabletop.yaml")
    scenes = -(-frames // views)  # every view is a frame
    frames = scenes * views
    render = dataclasses.replace(base.render, width=width, height=height, views=views)
    config = base.replace(num_samples=scenes, render=render)
    out = Path(tempfile.mkdtemp(prefix="datagen-vs-maniskill-"))
    done_times: list[float] = []  # scene k durable (1-based) -> the first moment it was

    def on_progress(done: int, total: int) -> None:
        done_times.extend([time.monotonic()] * (done - len(done_times)))

    try:
        start = time.monotonic()
        run_build(config, out, workers, on_progress=on_progress)
        seconds = time.monotonic() - start
        size = sum(p.stat().st_size for p in out.glob("*.tar"))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {"frames": frames, "seconds": round(seconds, 2), "frames_per_s": round(frames / seconds, 2),
            "workers": workers, "views": views, "bytes": size,
            # without the start-up (workers importing SAPIEN, the first render): the frames
            # after the first W scenes, over the time from the W-th to the last durable scene
            "steady_frames_per_s": round((scenes - workers) * views / (done_times[-1] - done_times[workers - 1]), 2)
            if scenes > workers else None}  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--views", type=int, default=4, help="render.views of the multi-view side")
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/vs_maniskill.json"))
    args = parser.parse_args()
    rows = {
        "ManiSkill RecordEpisode, 1 process": maniskill_fps(args.frames, args.width, args.height),
        "ManiSkill, new scene every 2 frames": maniskill_fps(
            args.frames, args.width, args.height, new_scene_per_frame=True
        ),
        f"datagen, {args.workers} workers": datagen_fps(
            args.frames, args.width, args.height, args.workers
        ),
        f"datagen, {args.workers} workers, {args.views} views": datagen_fps(
            args.frames, args.width, args.height, args.workers, args.views
        ),
        "datagen, 1 worker": datagen_fps(args.frames, args.width, args.height, 1),
    }
    ms = rows["ManiSkill RecordEpisode, 1 process"]["frames_per_s"]
    ms_new = rows["ManiSkill, new scene every 2 frames"]["frames_per_s"]
    ratios = {}
    for name, r in rows.items():
        if name.startswith("datagen"):
            ratios[f"{name} / ManiSkill stepping"] = round(r["frames_per_s"] / ms, 3)
            ratios[f"{name} / ManiSkill new scene every 2 frames"] = round(
                r["frames_per_s"] / ms_new, 3
            )
    print(f"{'side':38} {'frames':>6} {'s':>7} {'frames/s':>9} {'MB':>7}")
    for name, r in rows.items():
        print(f"{name:38} {r['frames']:>6} {r['seconds']:>7.1f} {r['frames_per_s']:>9.2f} {r['bytes'] / 2**20:>7.1f}")  # fmt: skip
    for name, value in ratios.items():
        print(f"ratio {name}: {value}")
    for name, r in rows.items():  # ManiSkill's figures exclude gym.make; datagen's include start-up
        if r.get("steady_frames_per_s"):
            print(f"{name}, steady (start-up excluded): {r['steady_frames_per_s']} frames/s, "
                  f"÷ ManiSkill stepping {r['steady_frames_per_s'] / ms:.3f}, "
                  f"÷ new scene every 2 frames {r['steady_frames_per_s'] / ms_new:.3f}")  # fmt: skip
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"command": " ".join(sys.argv), "resolution": [args.width, args.height], "rows": rows, "ratios": ratios}, indent=2))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
