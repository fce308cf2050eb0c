"""An example episode family, ``example_rolls``: a ball rolling across a floor, filmed from above
for ``FRAMES`` frames, in a metadata format of its own (``example.roll/1``,
``example_roll_format.py``). docs/extending.md walks it: the family writes its samples, the
format module tells every reader, tool and export what they hold, and neither touches datagen/.
"""

from __future__ import annotations

import numpy as np
import sapien

from datagen.config import BuildConfig
from datagen.geometry import look_at
from datagen.registries import SceneFamily
from datagen.sample import Sample, sample_key
from datagen.seeding import sample_rng
from datagen.sensing.annotate import LabelledObject, label_maps, object_view_records
from datagen.sensing.encode import View, encode_view, metadata_bytes
from datagen.sensing.render import capture, keep_renderer_alive

CLASSES = ("background", "floor", "ball")
FRAMES, FPS, RADIUS = 6, 10.0, 0.04  # frames, Hz, metres
CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def sample_roll(rng: np.random.Generator) -> dict:
    """The randomiser: where the ball starts, how fast it rolls (m/s), its colour."""
    return {
        "start": rng.uniform(-0.12, 0.0, 2).round(4).tolist(),
        "velocity": rng.uniform(0.05, 0.2, 2).round(4).tolist(),
        "colour": rng.uniform(0.3, 1.0, 3).round(3).tolist(),
    }


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    keep_renderer_alive()
    roll = sample_roll(sample_rng(seed, index, "roll", attempt))
    scene = sapien.Scene()
    scene.set_ambient_light([0.4, 0.4, 0.4])
    scene.add_directional_light([0.3, 0.2, -1.0], [1.0, 1.0, 1.0])
    floor = scene.add_ground(0.0)
    builder = scene.create_actor_builder()
    builder.add_sphere_visual(radius=RADIUS, material=[*roll["colour"], 1.0])
    builder.add_sphere_collision(radius=RADIUS)
    ball = builder.build_kinematic(name="ball")
    r = config.render
    camera = scene.add_camera("top", r.width, r.height, np.deg2rad(60), r.near, r.far)
    camera.entity.set_pose(sapien.Pose(look_at([0.0, -0.05, 0.6], [0.0, 0.0, 0.0])))
    parts, frames, calibration = {}, [], {}
    for k in range(FRAMES):
        xy = np.asarray(roll["start"]) + np.asarray(roll["velocity"]) * k / FPS
        pose = sapien.Pose([*xy, RADIUS])
        ball.set_pose(pose)
        scene.update_render()
        frame = capture(camera)
        obj = LabelledObject(
            1,
            "ball",
            2,
            ball.per_scene_id,
            pose.to_transformation_matrix(),
            [CUBE * RADIUS],
            np.eye(4),
            np.full(3, 2 * RADIUS),
        )
        instance, semantic = label_maps(frame, [obj], {floor.per_scene_id: 1})
        seen = object_view_records(frame, instance, [obj], r.near)
        things = [
            {
                "instance_id": 1,
                "class": "ball",
                "bbox_xyxy": o["bbox_xyxy"],
                "visible_fraction": o["visible_fraction"],
            }
            for o in seen
            if o["visible"]
        ]
        frames.append(
            {
                "frame": k,
                "time_s": round(k / FPS, 6),
                "ball_xy": np.round(xy, 5).tolist(),
                "extrinsics_world_to_camera": np.round(frame.extrinsics, 7).tolist(),
                "things": things,
            }
        )
        calibration = {
            "width": r.width,
            "height": r.height,
            "near": r.near,
            "far": r.far,
            "intrinsics": np.round(frame.intrinsics, 6).tolist(),
            "convention": "opencv",
            "depth_scale": 0.001,
        }
        parts |= encode_view(View(frame.rgb, frame.depth, instance, semantic), f"f{k:04d}.")
    metadata = {
        "format": "example.roll/1",
        "key": sample_key(index),
        "index": index,
        "seed": seed,
        "scene": "example_rolls",
        "classes": list(CLASSES),
        "camera": calibration,
        "frames": frames,
        "fps": FPS,
        "randomisation": {"roll": roll},
    }
    return Sample(index, parts | {"json": metadata_bytes(metadata)})


def classes(config: BuildConfig) -> tuple[str, ...]:
    return CLASSES


FAMILY = SceneFamily(
    "example_rolls",
    "a ball rolling across a floor, filmed from above (the docs/extending.md episode example)",
    produce="example_rolls:produce",
    classes="example_rolls:classes",
    metadata_formats=("example.roll/1",),
    episodes=True,
)
