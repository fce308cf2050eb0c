"""Strict config loading: every user mistake is a ConfigError naming the file and the key."""

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
        ("num_samples: many\n", "num_samples: expected int"),
        ("num_samples: 0\n", "num_samples: expected values in [1,"),
        ("objects:\n  count: [5, 2]\n", "objects.count: expected [min, max] with min <= max"),
        ("objects:\n  count: [1, 99]\n", "objects.count: expected values in [1, 32]"),
        ("objects:\n  families: [box, teapot]\n", "objects.families: expected a non-empty list"),
        ("render:\n  width: 2.5\n", "render.width: expected int"),
        ("scene: kitchen\n", "scene: expected one of"),
        ("version: 7\n", "version: this datagen reads config version 1"),
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

    reference = (Path(__file__).resolve().parents[1] / "configs" / "README.md").read_text()

    def keys(cls, prefix=""):
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if dataclasses.is_dataclass(hints[f.name]):
                yield from keys(hints[f.name], f"{prefix}{f.name}.")
            else:
                yield f"{prefix}{f.name}"

    missing = [k for k in keys(BuildConfig) if f"`{k}`" not in reference]
    assert missing == [], missing
