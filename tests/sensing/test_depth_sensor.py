"""The depth-sensor model on synthetic depth maps: its statistics and where its holes fall."""

from __future__ import annotations

import numpy as np
import pytest

from datagen.config.appearance import DepthSensorConfig
from datagen.sensing.depth_sensor import (
    draw_depth_sensor,
    sensor_depth,
    shadow_holes,
)

FOCAL = 400.0
K = np.array([[FOCAL, 0, 160.0], [0, FOCAL, 120.0], [0, 0, 1]])
GREY = np.full((240, 320, 3), 128, np.uint8)
NOTHING = np.zeros((240, 320), np.uint16)
# every hole and step off: only what a test turns on acts
QUIET = {
    "noise_a": 0.0, "noise_b": 0.0, "baseline": 0.0, "disparity_step": 0.0, "edge_jump": 1.0,
    "edge_width_px": 0, "dark_threshold": 0.0, "dark_dropout": 0.0, "specular_instances": [],
    "specular_dropout": 0.0, "seed": 7,
}  # fmt: skip


def plane(z_m: float) -> np.ndarray:
    return np.full((240, 320), round(z_m * 1000), np.uint16)


def test_quiet_model_returns_the_clean_depth():
    depth = plane(1.234)
    depth[:10] = 0
    np.testing.assert_array_equal(sensor_depth(depth, GREY, NOTHING, K, QUIET), depth)


@pytest.mark.parametrize("z", [0.5, 1.0, 2.0, 3.5])
def test_noise_std_grows_as_a_plus_b_z_squared(z):
    values = QUIET | {"noise_a": 0.001, "noise_b": 0.003}
    error_m = (sensor_depth(plane(z), GREY, NOTHING, K, values).astype(float) - plane(z)) / 1000
    model = 0.001 + 0.003 * z**2
    expected = np.sqrt(model**2 + (0.001**2) / 12)  # + rounding to whole millimetres
    assert abs(error_m.mean()) < 0.05 * expected
    assert error_m.std() == pytest.approx(expected, rel=0.05)


def test_holes_follow_depth_edges_only():
    depth = plane(1.0)
    depth[:, 160:] = 1200  # a 20 % jump between columns 159 and 160
    depth[100:, :] += np.arange(140, dtype=np.uint16)[:, None]  # a gentle slope: no edge
    values = QUIET | {"edge_jump": 0.05, "edge_width_px": 2}
    holes = sensor_depth(depth, GREY, NOTHING, K, values) == 0
    assert holes[:, 158:162].all()  # two pixels on each side of the jump
    assert not holes[:, :158].any() and not holes[:, 162:].any()


@pytest.mark.parametrize("baseline", [0.05, -0.05])
def test_projector_shadow_lies_on_the_side_away_from_the_projector(baseline):
    depth = plane(1.5)
    depth[80:160, 140:180] = 750  # a box 0.75 m in front of a wall 1.5 m away
    holes = shadow_holes(depth / 1000.0, FOCAL, baseline)
    width = FOCAL * abs(baseline) * (1 / 0.75 - 1 / 1.5)  # 13.3 px of wall the projector misses
    shadow_cols = np.nonzero(holes[120])[0]
    if baseline > 0:  # projector right of the camera: shadow left of the box
        assert shadow_cols.max() == 139 and shadow_cols.min() == pytest.approx(140 - width, abs=1)
    else:
        assert shadow_cols.min() == 180 and shadow_cols.max() == pytest.approx(179 + width, abs=1)
    assert not holes[:80].any() and not holes[160:].any()  # rows without the box
    assert not holes[80:160, 140:180].any()  # the box itself is lit


def test_disparity_quantisation_makes_steps_growing_as_z_squared():
    ramp = np.tile(np.linspace(1000, 3000, 320).astype(np.uint16), (240, 1))
    step, baseline = 0.25, 0.05
    values = QUIET | {"baseline": baseline, "disparity_step": step}
    out = sensor_depth(ramp, GREY, NOTHING, K, values)[0].astype(float) / 1000
    disparity = FOCAL * baseline / out
    # whole multiples of the step, up to the rounding of depth to millimetres (< 0.05 %)
    np.testing.assert_allclose(disparity / step, np.rint(disparity / step), rtol=5e-4)
    levels = np.unique(out)
    gaps, middles = np.diff(levels), (levels[1:] + levels[:-1]) / 2
    np.testing.assert_allclose(gaps, middles**2 * step / (FOCAL * baseline), rtol=0.05)


def test_dark_and_specular_pixels_drop_out_at_their_rates():
    depth, rgb, instance = plane(1.0), GREY.copy(), NOTHING.copy()
    rgb[:, :100] = 3  # nearly black
    instance[:, 200:] = 4  # a specular object
    values = QUIET | {"dark_threshold": 0.01, "dark_dropout": 0.6}
    values |= {"specular_instances": [4], "specular_dropout": 0.3}
    holes = sensor_depth(depth, rgb, instance, K, values) == 0
    assert holes[:, :100].mean() == pytest.approx(0.6, abs=0.02)
    assert holes[:, 200:].mean() == pytest.approx(0.3, abs=0.02)
    assert not holes[:, 100:200].any()


def test_values_come_from_the_stream_and_replay_the_same_image():
    cfg = DepthSensorConfig()
    values = draw_depth_sensor(np.random.default_rng(3), cfg, [2])
    assert values == draw_depth_sensor(np.random.default_rng(3), cfg, [2])
    assert values != draw_depth_sensor(np.random.default_rng(4), cfg, [2])
    assert cfg.baseline[0] <= values["baseline"] <= cfg.baseline[1]
    depth = plane(1.2)
    depth[50:90, 50:90] = 800
    first = sensor_depth(depth, GREY, NOTHING, K, values)
    np.testing.assert_array_equal(first, sensor_depth(depth, GREY, NOTHING, K, values))
    assert not np.array_equal(first, depth)
