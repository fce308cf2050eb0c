"""Config dicts of the training sets and the held-out sources of the test domains. Every
training set draws textures only from ``TRAIN_TEXTURES``, light within ``TRAIN_LIGHTING`` and
photographs only from ``photos.sources``; a test domain swaps one of them for what no set drew.
The dicts are validated when built (``building.build``)."""

from __future__ import annotations

import copy
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TRAIN_TEXTURES = ["noise", "stripes", "checker"]
HELD_OUT_TEXTURES = ["marble", "grain", "speckle"]
TRAIN_LIGHTING = {"ambient": [0.08, 0.6], "intensity": [0.3, 2.4]}
HELD_OUT_LIGHTING = {"ambient": [0.02, 0.08], "intensity": [2.4, 4.0]}
# the lighting before issue 26 (narrow, white, hard shadows), inside the training band
BEFORE_LIGHTING = {
    "ambient": [0.15, 0.45],
    "lights": [1, 3],
    "intensity": [0.6, 2.0],
    "elevation_deg": [35, 85],
    "colour_temperature_k": [6500, 6500],
    "soft_shadow_probability": 0.0,
}
WITHOUT = {  # c_no_<name>: what (c) turns off
    "photo_surfaces": {"photos": {"surface_probability": 0.0}},
    "photo_backdrops": {"photos": {"backdrop_probability": 0.0}},
    "flying": {"distractors": {"flying": [0, 0]}},
    "wide_lighting": {"lighting": BEFORE_LIGHTING},
    "class_colours": {"materials": {"class_independent_probability": 0.0}},
}
TRAINING_SETS = ("a_flat", "b_textures_room", "c_default", *(f"c_no_{name}" for name in WITHOUT))
TRAIN_SEED, TEST_SEED = 1, 99


def merged(base: dict, overrides: dict) -> dict:
    """``base`` with ``overrides`` written over it, nested sections merged key by key."""
    result = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(result.get(key), dict):
            result[key] = merged(result[key], value)
        else:
            result[key] = value
    return result


def repo_config(name: str) -> dict:
    from datagen.config.yaml_file import read_yaml

    return read_yaml(REPO / "configs" / name)


def training_sets(view: dict, scenes: int) -> dict[str, dict]:
    """Each training set of ``TRAINING_SETS`` with ``scenes`` scenes (seed ``TRAIN_SEED``),
    ``view`` (render size, cameras, robot pose) written over its recipe:

    - ``a_flat``: ``configs/grasp_flat.yaml`` (flat colours, primitives, nothing around);
    - ``b_textures_room``: (a) with procedural textures and the room (no photographs);
    - ``c_default``: the default config, everything on;
    - ``c_no_<randomiser>``: (c) without one of ``WITHOUT``."""
    flat = repo_config("grasp_flat.yaml")
    default = repo_config("grasp_tabletop.yaml")
    train = view | {"num_samples": scenes, "seed": TRAIN_SEED, "lighting": TRAIN_LIGHTING}
    families = {"materials": {"texture_families": TRAIN_TEXTURES}}
    room = {
        "materials": merged(default["materials"], families["materials"]),
        "background": default["background"],
    }
    c = merged(merged(default, families), train)
    return {
        "a_flat": merged(flat, train),
        "b_textures_room": merged(merged(flat, room), train),
        "c_default": c,
    } | {f"c_no_{name}": merged(c, off) for name, off in WITHOUT.items()}


def held_out_photos(default: dict) -> dict:
    """Photographs of the held-out library sources only, on 90 % of the surfaces, every wall and
    every flying card."""
    return {
        "photos": {
            "sources": default["photos"]["held_out"],
            "held_out": default["photos"]["sources"],
            "surface_probability": 0.9,
            "backdrop_probability": 1.0,
            "distractor_probability": 1.0,
        },
    }


def real_meshes() -> dict:
    """The library's real object meshes (robosuite's) instead of procedural shapes."""
    from datagen.library.catalogue import library_root

    return {
        "objects": {"source": "folder", "assets_dir": str(library_root() / "robosuite-objects")}
    }
