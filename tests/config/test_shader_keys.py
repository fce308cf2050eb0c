"""``render.shader`` and the path tracer's keys validate like every other key: a bad value is a
ConfigError naming the file and the key."""

import pytest

from datagen.config import BuildConfig, load_config
from datagen.errors import ConfigError


def write(tmp_path, text):
    path = tmp_path / "build.yaml"
    path.write_text(text)
    return path


def test_rasterized_is_the_default():
    render = BuildConfig().render
    assert (render.shader, render.denoiser, render.raytraced_share) == ("rasterized", "none", 1.0)
    assert (render.samples_per_pixel, render.path_depth) == (16, 8)


def test_path_tracing_keys_load(tmp_path):
    text = (
        "render:\n  shader: raytraced\n  samples_per_pixel: 4\n  path_depth: 0\n"
        "  denoiser: oidn\n  raytraced_share: 0.25\n"
    )
    render = load_config(write(tmp_path, text)).render
    assert (render.shader, render.samples_per_pixel, render.path_depth) == ("raytraced", 4, 0)
    assert (render.denoiser, render.raytraced_share) == ("oidn", 0.25)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "render:\n  shader: pathtraced\n",
            "render.shader: expected one of ['rasterized', 'raytraced'], got 'pathtraced'",
        ),
        ("render:\n  shader: 3\n", "render.shader: expected a string, got 3"),
        (
            "render:\n  denoiser: fast\n",
            "render.denoiser: expected one of ['none', 'oidn', 'optix'], got 'fast'",
        ),
        ("render:\n  samples_per_pixel: 0\n", "render.samples_per_pixel: expected values in [1,"),
        ("render:\n  samples_per_pixel: 2.5\n", "render.samples_per_pixel: expected a whole"),
        ("render:\n  path_depth: 33\n", "render.path_depth: expected values in [0, 32]"),
        ("render:\n  raytraced_share: 1.5\n", "render.raytraced_share: expected values in [0.0,"),
        ("render:\n  raytraced_share: half\n", "render.raytraced_share: expected a finite number"),
        (
            "scene: navigation\nrender:\n  shader: raytraced\n",
            "render.shader: 'raytraced' views are rendered by the tabletop scenes",
        ),
    ],
)
def test_bad_shader_key_names_file_and_key(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(path) in str(info.value)
    assert expected in str(info.value)
