"""Strict config loading: every user mistake is a ConfigError naming the file and the key."""

import os

import pytest

from datagen.config import BuildConfig, load_config
from datagen.errors import ConfigError


def write(tmp_path, text):
    path = tmp_path / "build.yaml"
    path.write_text(text)
    return path


def test_default_config_file_equals_defaults():
    assert load_config("configs/grasp_tabletop.yaml") == BuildConfig()


def test_empty_file_gives_defaults(tmp_path):
    assert load_config(write(tmp_path, "")) == BuildConfig()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("objects:\n  colour: red\n", "unknown key(s) objects.colour"),
        ("bogus: 1\n", "unknown key(s) bogus"),
        ("num_samples: many\n", "num_samples: expected a whole number, got 'many'"),
        ("num_samples: 0\n", "num_samples: expected values in [1,"),
        ("objects:\n  count: [5, 2]\n", "objects.count: expected [min, max] with min <= max"),
        ("objects:\n  count: [1, 99]\n", "objects.count: expected values in [1, 32]"),
        ("objects:\n  families: [box, teapot]\n", "objects.families: expected a non-empty list"),
        ("render:\n  width: 2.5\n", "render.width: expected a whole number, got 2.5"),
        ("scene: kitchen\n", "scene: expected one of"),
        ("version: 7\n", "version: this datagen reads config versions 1 and 2, got 7"),
        ("- a\n- b\n", "expected a mapping"),
        ("objects: [\n", "not valid YAML"),
    ],
)
def test_bad_config_names_file_and_key(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(path) in str(info.value)
    assert expected in str(info.value)


def test_missing_file():
    with pytest.raises(ConfigError, match="no such config file"):
        load_config("configs/does-not-exist.yaml")


def test_config_round_trips_through_dict():
    from datagen.config import config_from_dict

    config = BuildConfig().replace(num_samples=7, seed=3)
    assert config_from_dict(config.to_dict()) == config


def test_reference_documents_every_key():
    import dataclasses
    import typing
    from pathlib import Path

    reference = (Path(__file__).resolve().parents[2] / "configs" / "README.md").read_text()

    def keys(cls, prefix=""):
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if dataclasses.is_dataclass(hints[f.name]):
                yield from keys(hints[f.name], f"{prefix}{f.name}.")
            else:
                yield f"{prefix}{f.name}"

    missing = [k for k in keys(BuildConfig) if f"`{k}`" not in reference]
    assert missing == [], missing


# --- bad input: the key, the expected shape, never a traceback (issue 14) ---


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("camera:\n  eye_jitter: .nan\n", "camera.eye_jitter: expected a finite number, got nan"),
        ("render:\n  near: .inf\n", "render.near: expected a finite number, got inf"),
        ("objects:\n  size: [-.inf, 0.1]\n", "objects.size: expected a [min, max] pair of finite"),
        ("camera:\n  eye: [.nan, 0, 1]\n", "camera.eye: expected a list of 3 finite numbers"),
        ("objects:\n  count: 3\n", "objects.count: expected a [min, max] pair of whole numbers"),
        ("objects:\n  count: [1, 2, 3]\n", "objects.count: expected a [min, max] pair"),
        ("objects:\n  count: {a: 1}\n", "objects.count: expected a [min, max] pair"),
        ("objects:\n  size: 0.1\n", "objects.size: expected a [min, max] pair of finite numbers"),
        ("objects:\n  families: box\n", "objects.families: expected a list of strings"),
        ("output:\n  formats: webdataset\n", "output.formats: expected a list of strings"),
        ("objects:\n  families: [1, 2]\n", "objects.families: expected a list of strings"),
        ("camera:\n  eye: [1, 2]\n", "camera.eye: expected a list of 3 finite numbers [x, y, z]"),
        ("camera:\n  eye: null\n", "camera.eye: expected a list of 3 finite numbers"),
        ("navigation:\n  clutter: 3\n", "navigation.clutter: expected a [min, max] pair of whole numbers or null"),
        ("objects:\n  count: [0, 4]\n", "objects.count: expected values in [1, 32]"),
        ("render:\n  width: true\n", "render.width: expected a whole number, got True"),
        ("render:\n  wrist_camera: 1\n", "render.wrist_camera: expected true or false, got 1"),
        ("lighting:\n  shadows: 'yes'\n", "lighting.shadows: expected true or false, got 'yes'"),
        ("render:\n  near: false\n", "render.near: expected a finite number, got False"),
        ("version: true\n", "version: this datagen reads config versions 1 and 2, got True"),
        ("num_samples: 1.0e+12\n", "num_samples: expected a whole number, got 1000000000000.0"),
        ("num_samples: " + "9" * 40 + "\n", "num_samples: expected values in [1, 999999999]"),
        ("render: null\n", "render: expected a mapping of keys, got None"),
        ("scene: 3\n", "scene: expected a string, got 3"),
        ("camera:\n  eye: [0.1, 0.2, 1.0]\n  target: [0.1, 0.2, 1.0]\n", "camera.eye: expected a point other than camera.target"),
        ("camera:\n  eye: [0, 0, 1]\n  target: [0, 0, 0.9]\n", "farther from it than the jitter reaches"),
        ("camera:\n  eye: [1000, 0, 1]\n", "camera.eye: expected values in [-100.0, 100.0]"),
    ],
)  # fmt: skip
def test_wrong_types_and_shapes_name_the_key_and_the_expected_shape(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and expected in message, message
    assert "\n" not in message and len(message) < 400


def test_eye_and_target_may_be_close_without_jitter(tmp_path):
    text = "camera:\n  eye: [0, 0, 1]\n  target: [0, 0, 0.9]\n  eye_jitter: 0\n  target_jitter: 0\n"
    assert load_config(write(tmp_path, text)).camera.eye == (0, 0, 1)


BOMB = "".join(
    f"  - &a{i} [{', '.join([f'*a{i - 1}'] * 9) if i else ', '.join(['lol'] * 9)}]\n"
    for i in range(10)
)  # 9^9 strings once expanded


@pytest.mark.parametrize(
    "text",
    [
        f"output:\n  formats:\n{BOMB}",  # the blow-up would happen while the value is checked
        f"objects:\n  families:\n{BOMB}",
        f"bogus:\n{BOMB}",
    ],
)
def test_an_alias_bomb_fails_fast(tmp_path, text):
    import time

    path = write(tmp_path, text)
    start = time.monotonic()
    with pytest.raises(ConfigError, match="aliases expand to more than 10000 values"):
        load_config(path)
    assert time.monotonic() - start < 0.5


def test_a_few_aliases_are_fine_and_a_recursive_one_is_refused(tmp_path):
    text = "objects:\n  size: &s [0.05, 0.1]\nnavigation:\n  clutter_size: *s\n"
    assert load_config(write(tmp_path, text)).navigation.clutter_size == (0.05, 0.1)
    with pytest.raises(ConfigError, match="refers to a node that contains it"):
        load_config(write(tmp_path, "output:\n  formats: &x [*x]\n"))


@pytest.mark.parametrize(
    ("make", "expected"),
    [
        (lambda d: d, "is a directory; expected a YAML config file"),
        (lambda d: d / "missing.yaml", "no such config file"),
        (lambda d: d / "file.txt" / "config.yaml", "no such config file"),
        (lambda d: _bytes(d, b"scene: \xff\xfe\n"), "not UTF-8 text (byte 0xff at offset 7)"),
        (lambda d: _bytes(d, b"# " + b"x" * (1 << 20) + b"\n"), "larger than 1 MiB"),
        (lambda d: _bytes(d, b"a: " + b"[" * 5000 + b"\n"), "not valid YAML"),
        (lambda d: _bytes(d, b"seed: " + b"9" * 5000 + b"\n"), "not valid YAML"),
        (lambda d: _bytes(d, b"a: !!python/object:os.system x\n"), "not valid YAML"),
        (lambda d: _bytes(d, b"a: 1\n---\nb: 2\n"), "not valid YAML"),
    ],
)
def test_unusable_config_files_are_one_line_naming_the_path(tmp_path, make, expected):
    (tmp_path / "file.txt").write_text("not a directory")
    path = make(tmp_path)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith(str(path)) and expected in message, message
    assert "\n" not in message


def _bytes(directory, data: bytes):
    path = directory / "config.yaml"
    path.write_bytes(data)
    return path


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_an_unreadable_config_file_is_one_line(tmp_path):
    path = write(tmp_path, "seed: 1\n")
    path.chmod(0)
    with pytest.raises(ConfigError, match="cannot read the config file: Permission denied"):
        load_config(path)


def test_a_version_1_config_is_read_with_a_notice_for_its_renamed_key(tmp_path, caplog):
    old = write(tmp_path, "version: 1\noutput:\n  sinks: [webdataset, coco]\n")
    with caplog.at_level("WARNING", logger="datagen.config"):
        config = load_config(old)
    assert config.version == 2 and config.output.formats == ("webdataset", "coco")
    notices = [r.getMessage() for r in caplog.records]
    assert len(notices) == 1 and "output.sinks is read as output.formats" in notices[0]
    assert str(old) in notices[0] and "\n" not in notices[0]
    new = write(tmp_path, "version: 2\noutput:\n  formats: [webdataset, coco]\n")
    assert load_config(new) == config
    with pytest.raises(ConfigError, match=r"unknown key\(s\) output.sinks"):
        load_config(write(tmp_path, "version: 2\noutput:\n  sinks: [webdataset]\n"))
    both = "version: 1\noutput:\n  sinks: [webdataset]\n  formats: [webdataset]\n"
    with pytest.raises(ConfigError, match="the same key, named 'sinks' in config version 1"):
        load_config(write(tmp_path, both))
