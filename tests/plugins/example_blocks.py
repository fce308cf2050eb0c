"""An example scene family, ``example_blocks``: 1-4 coloured blocks on a floor, seen from above.

It is what docs/extending.md walks through: one module with a randomiser (``sample_blocks``: a
pure sampler, rng in, JSON values out) and a ``produce`` function, registered by one entry point
(``datagen.families``). Its samples use the standard per-camera metadata, so every export,
``preview`` and ``inspect`` read them without knowing this family exists.

Tests only: ``EXAMPLE_BLOCKS_FAIL="3:1,5:99"`` makes sample 3 fail once and sample 5 always
(index:attempts that raise), to exercise ``build.on_sample_error``; ``EXAMPLE_BLOCKS_HANG`` (same
form) makes those attempts hang for good instead (heartbeats go on), to exercise
``build.sample_timeout_s``.
"""

from __future__ import annotations

import os
import threading

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

CLASSES = ("background", "floor", "block")
CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def sample_blocks(rng: np.random.Generator) -> list[dict]:
    """The randomiser: how many blocks, where, how big, what colour."""
    return [
        {
            "half_size": rng.uniform(0.02, 0.06, 3).round(4).tolist(),
            "xy": rng.uniform(-0.15, 0.15, 2).round(4).tolist(),
            "yaw": round(float(rng.uniform(0, np.pi)), 4),
            "colour": rng.uniform(0.2, 1.0, 3).round(3).tolist(),
        }
        for _ in range(int(rng.integers(1, 5)))
    ]


def _injected(variable: str, index: int, attempt: int) -> bool:
    for item in filter(None, os.environ.get(variable, "").split(",")):
        faulty_index, faulty_attempts = map(int, item.split(":"))
        if index == faulty_index and attempt < faulty_attempts:
            return True
    return False


def _maybe_fail(index: int, attempt: int) -> None:
    if _injected("EXAMPLE_BLOCKS_FAIL", index, attempt):
        raise RuntimeError(f"injected fault in sample {index}, attempt {attempt}")
    if _injected("EXAMPLE_BLOCKS_HANG", index, attempt):
        threading.Event().wait()  # forever, the GIL released: only the time limit ends it


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    _maybe_fail(index, attempt)
    keep_renderer_alive()
    blocks = sample_blocks(sample_rng(seed, index, "blocks", attempt))
    scene = sapien.Scene()
    scene.set_ambient_light([0.4, 0.4, 0.4])
    scene.add_directional_light([0.3, 0.2, -1.0], [1.0, 1.0, 1.0])
    floor = scene.add_ground(0.0)
    objects = []
    for i, block in enumerate(blocks, start=1):
        half = np.asarray(block["half_size"])
        builder = scene.create_actor_builder()
        builder.add_box_collision(half_size=half)
        builder.add_box_visual(half_size=half, material=[*block["colour"], 1.0])
        pose = sapien.Pose(
            [*block["xy"], half[2]], [np.cos(block["yaw"] / 2), 0, 0, np.sin(block["yaw"] / 2)]
        )
        entity = builder.build_static(name=f"block{i}")
        entity.set_pose(pose)
        objects.append(
            LabelledObject(i, "block", 2, entity.per_scene_id, pose.to_transformation_matrix(),
                           [CORNERS * half], np.eye(4), 2 * half)
        )  # fmt: skip
    r = config.render
    camera = scene.add_camera("workspace", r.width, r.height, np.deg2rad(50), r.near, r.far)
    camera.entity.set_pose(sapien.Pose(look_at([0.0, -0.35, 0.5], [0.0, 0.0, 0.0])))
    scene.update_render()
    frame = capture(camera)
    instance, semantic = label_maps(frame, objects, {floor.per_scene_id: 1})
    view = {
        "camera": {
            "width": r.width, "height": r.height, "near": r.near, "far": r.far,
            "intrinsics": np.round(frame.intrinsics, 6).tolist(),
            "extrinsics_world_to_camera": np.round(frame.extrinsics, 7).tolist(),
            "convention": "opencv", "depth_scale": 0.001,
        },
        "objects": object_view_records(frame, instance, objects, r.near),
    }  # fmt: skip
    metadata = {
        "format": "datagen.sample/1", "key": sample_key(index), "index": index, "seed": seed,
        "scene": "example_blocks", "classes": list(CLASSES), "views": {"workspace": view},
        "objects": [], "randomisation": {"blocks": blocks},
    }  # fmt: skip
    parts = encode_view(View(frame.rgb, frame.depth, instance, semantic))
    return Sample(index, parts | {"json": metadata_bytes(metadata)})


def classes(config: BuildConfig) -> tuple[str, ...]:
    return CLASSES


FAMILY = SceneFamily(
    "example_blocks",
    "coloured blocks on a floor (the docs/extending.md example)",
    produce="example_blocks:produce",
    classes="example_blocks:classes",
)
