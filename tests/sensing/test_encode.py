"""PNG encoding: the ``output.png_level`` key, the thread pool, and what each level decodes to."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from datagen.config import load_config
from datagen.errors import ConfigError
from datagen.sensing.encode import View, encode_view, png_bytes

REPO = Path(__file__).resolve().parents[2]


def _view(seed: int, height: int = 96, width: int = 128) -> View:
    rng = np.random.default_rng(seed)
    # blocks of constant value, like rendered label maps, plus noise in colour and depth
    blocks = rng.integers(0, 40, size=(height // 8, width // 8)).repeat(8, 0).repeat(8, 1)
    return View(
        rgb=rng.integers(0, 256, size=(height, width, 3), dtype=np.uint8),
        depth=(blocks * 50 + rng.integers(0, 3, size=blocks.shape)).astype(np.uint16),
        instance=blocks.astype(np.uint16),
        semantic=(blocks % 7).astype(np.uint8),
    )


@pytest.mark.parametrize("level", range(10))
def test_thread_pool_gives_the_bytes_of_serial_encoding(level):
    for seed in range(3):
        view = _view(seed)
        assert encode_view(view, "a.", level) == encode_view(view, "a.", level, parallel=False)


@pytest.mark.parametrize("level", range(10))
def test_every_level_decodes_to_the_same_pixels(level):
    view = _view(7)
    parts = encode_view(view, "", level)
    flags = cv2.IMREAD_UNCHANGED
    decoded_rgb = cv2.imdecode(np.frombuffer(parts["rgb.png"], np.uint8), flags)
    assert np.array_equal(cv2.cvtColor(decoded_rgb, cv2.COLOR_BGR2RGB), view.rgb)
    for name, image in (("depth", view.depth), ("seg", view.instance), ("semantic", view.semantic)):
        decoded = cv2.imdecode(np.frombuffer(parts[f"{name}.png"], np.uint8), flags)
        assert decoded.dtype == image.dtype and np.array_equal(decoded, image)


def test_default_level_is_the_bytes_datagen_always_wrote():
    """Level 1 is OpenCV's speed preset (no parameters), not ``IMWRITE_PNG_COMPRESSION=1``."""
    view = _view(3)
    assert png_bytes(view.depth) == cv2.imencode(".png", view.depth)[1].tobytes()
    explicit = cv2.imencode(".png", view.depth, [cv2.IMWRITE_PNG_COMPRESSION, 1])[1].tobytes()
    assert png_bytes(view.depth) != explicit
    assert len(png_bytes(view.depth, 9)) < len(png_bytes(view.depth))


def _write(tmp_path, text: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return path


def test_png_level_key_accepts_0_to_9(tmp_path):
    assert load_config(_write(tmp_path, "")).output.png_level == 1
    for level in (0, 9):
        assert (
            load_config(_write(tmp_path, f"output:\n  png_level: {level}\n")).output.png_level
            == level
        )


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ("10", "output.png_level: expected values in [0, 9]"),
        ("-1", "output.png_level: expected values in [0, 9]"),
        ("fast", "output.png_level: expected a whole number, got 'fast'"),
        ("1.5", "output.png_level: expected a whole number"),
    ],
)
def test_bad_png_level_names_the_key(tmp_path, value, expected):
    path = _write(tmp_path, f"output:\n  png_level: {value}\n")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value).startswith(f"{path}: ") and expected in str(info.value)


def test_bad_png_level_on_the_command_line_is_exit_code_2_without_traceback(tmp_path):
    config = _write(tmp_path, "output:\n  png_level: 12\n")
    result = subprocess.run(
        [sys.executable, "-m", "datagen.cli", "build", str(config), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr
    assert "output.png_level: expected values in [0, 9]" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout
