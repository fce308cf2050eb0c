"""Read-back conversions: the one-pass conversions equal the straightforward reference, bit for
bit, on real captures and on edge values; the torch variant (the GPU path) equals both."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from datagen.config import load_config
from datagen.sensing import picture_conversion as conversion
from datagen.sensing import stage_clock
from datagen.sensing.render import (
    _pictures_cpu,
    _pictures_gpu,
    capture,
    gpu_read_back,
    keep_renderer_alive,
)

pytestmark = pytest.mark.filterwarnings("ignore:invalid value encountered in cast")


def _colour_edges(rng) -> np.ndarray:
    k = np.arange(256, dtype=np.float32)
    half = (k + 0.5) / np.float32(255)  # x * 255 + 0.5 lands on or next to a whole number
    values = np.concatenate(
        [
            k / np.float32(255),
            half,
            np.nextafter(half, np.float32(0)),
            np.nextafter(half, np.float32(1)),
            np.float32([0, 1, -0.0, -1e-8, 1 + 1e-7, 2, -3, np.inf, -np.inf, np.nan]),
            rng.random(2000, dtype=np.float32),
        ]
    )
    values = np.resize(values, (values.size + 3) // 4 * 4).astype(np.float32)
    return values.reshape(-1, 2, 2)[:, None].reshape(-1, 1, 4)  # (N, 1, 4) rgba pixels


def _position_edges(rng) -> np.ndarray:
    mm = np.arange(0, 70_000, dtype=np.float32)  # past 65.535 m: clipped to the uint16 maximum
    scale = np.float32(0.001)
    z = np.concatenate(
        [
            -mm * scale,
            -(mm + np.float32(0.5)) * scale,  # rounding ties of rint (half to even)
            np.nextafter(-(mm + np.float32(0.5)) * scale, np.float32(0)),
            np.float32([0.0, -0.0, 1.0, -100, -1e9, np.inf, -np.inf, np.nan]),
            -rng.random(5000, dtype=np.float32) * 5,
        ]
    )
    w_choices = np.float32(
        [0.5, 0.99, 0.9999999, 1.0, 1.0000001, 2.0, np.nan]
    )  # w >= 1: no surface
    w = rng.choice(w_choices, size=z.size).astype(np.float32)
    w[: z.size // 2] = 0.9
    position = np.zeros((z.size, 1, 4), np.float32)
    position[:, 0, 2], position[:, 0, 3] = z, w
    return position


def test_conversions_equal_the_reference_on_edge_values():
    rng = np.random.default_rng(15)
    rgba, position = _colour_edges(rng), _position_edges(rng)
    assert np.array_equal(conversion.rgb_from_colour(rgba), conversion.rgb_reference(rgba))
    depth = conversion.depth_from_position(position)
    assert np.array_equal(depth, conversion.depth_reference(position))
    assert depth.max() == conversion.DEPTH_MAX_UNITS and (depth == 0).sum() > 1000


def test_torch_conversions_give_the_same_bytes_on_cpu_tensors():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(16)
    rgba, position = _colour_edges(rng), _position_edges(rng)
    rgb = conversion.rgb_from_colour_torch(torch.from_numpy(rgba)).numpy()
    assert rgb.dtype == np.uint8 and np.array_equal(rgb, conversion.rgb_reference(rgba))
    depth = conversion.depth_from_position_torch(torch.from_numpy(position)).numpy()
    assert np.array_equal(depth.astype(np.uint16), conversion.depth_reference(position))


def test_scratch_buffers_are_never_handed_out():
    rgba = np.random.default_rng(0).random((6, 5, 4), dtype=np.float32)
    first = conversion.rgb_from_colour(rgba)
    conversion.rgb_from_colour(1 - rgba)
    assert np.array_equal(first, conversion.rgb_reference(rgba))


@pytest.mark.sim
@pytest.mark.slow  # the first capture of a process compiles lavapipe's pipelines
def test_capture_equals_the_reference_on_real_pictures():
    """The default grasp scene (small), plus an empty scene whose camera sees only the far
    plane; the pictures of each capture are read again and converted the reference way."""
    import sapien

    from datagen.families.grasp_tabletop.world import build_scene

    config = load_config("configs/grasp_tabletop.yaml")
    config = config.replace(render=replace(config.render, width=128, height=96))
    keep_renderer_alive()
    scene = build_scene(config, config.seed, 3)
    scene.scene.update_render()
    empty = sapien.Scene()
    sky = empty.add_camera("sky", 64, 48, 1.0, 0.05, 5.0)
    sky.entity.set_pose(sapien.Pose([0, 0, 1], [0.7071068, 0, -0.7071068, 0]))  # looks up
    empty.update_render()

    assert not gpu_read_back(False)
    for camera in (scene.cameras["workspace"], sky):
        stage_clock.take()
        frame = capture(camera)
        assert {"render_s", "read_back_s", "convert_s"} <= set(stage_clock.take())
        rgba, position = camera.get_picture("Color"), camera.get_picture("Position")
        segmentation = camera.get_picture("Segmentation")
        assert np.array_equal(frame.rgb, conversion.rgb_reference(rgba))
        assert np.array_equal(frame.depth, conversion.depth_reference(position))
        assert np.array_equal(frame.entity_ids, segmentation[..., 1])
        assert frame.entity_ids.flags.c_contiguous and frame.depth.dtype == np.uint16
    assert (frame.depth == 0).all() and (position[..., 3] >= 1).all()  # the sky: no surface


@pytest.mark.sim
@pytest.mark.skipif(
    not Path("/dev/nvidiactl").exists(), reason="needs an NVIDIA GPU (SAPIEN on CUDA, torch)"
)
def test_gpu_read_back_gives_the_cpu_paths_bytes():
    """On a CUDA render device the pictures read back and converted on the GPU (what
    ``capture`` does there) are the CPU path's bytes, at the default 640x480."""
    from datagen.families.grasp_tabletop.world import build_scene

    config = load_config("configs/grasp_tabletop.yaml")
    keep_renderer_alive()
    scene = build_scene(config, config.seed, 3)
    scene.scene.update_render()
    camera = scene.cameras["workspace"]
    assert camera.entity.scene.render_system.device.is_cuda(), "SAPIEN renders on the CPU"
    assert gpu_read_back(True), "torch sees no CUDA device"
    on_gpu, on_cpu = _pictures_gpu(camera), _pictures_cpu(camera)
    for name, gpu, cpu in zip(("rgb", "depth", "entity ids"), on_gpu, on_cpu, strict=True):
        assert gpu.dtype == cpu.dtype and np.array_equal(gpu, cpu), name
