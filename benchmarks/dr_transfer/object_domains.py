"""What ``object_transfer.py`` builds: the training sets of ``variants.training_sets`` and
five test domains, every one seen by the wrist camera the arm holds over the tray.

Each test domain is the default set's recipe (training texture families, lighting within the
training band, photographs of the training sources) with its own seed and one thing no
training set drew: the held-out photographs, the library's real meshes, lighting outside the
band, the held-out texture families (and no photographs, so every textured surface shows
one), or path-traced colour images."""

from __future__ import annotations

from datagen.config.sections import PRIMITIVE_FAMILIES
from dr_transfer.variants import (
    HELD_OUT_LIGHTING,
    HELD_OUT_TEXTURES,
    TEST_SEED,
    TRAIN_LIGHTING,
    TRAIN_TEXTURES,
    TRAINING_SETS,
    WITHOUT,
    held_out_photos,
    merged,
    real_meshes,
    repo_config,
    training_sets,
)

TEST_DOMAINS = {
    "photos": "held-out photographs",
    "meshes": "real meshes",
    "lighting": "lighting outside the band",
    "textures": "held-out texture families",
    "raytraced": "path-traced",
}
# the randomisers that act on the objects and the wrist camera's view of them: c_no_<name> is
# the default set with one turned off, c_with_<name> with one added
OBJECT_WITHOUT = {
    "surface_textures": {  # pictures and procedural textures on objects and surfaces
        "materials": {"texture_probability": 0.0},
        "photos": {"surface_probability": 0.0},
    },
    "household_shapes": {"objects": {"families": list(PRIMITIVE_FAMILIES)}},
    "size_range": {"objects": {"size": [0.07, 0.07]}},  # metres: the default range's middle
    "clutter": {"objects": {"count": [1, 3]}},
    "look_variety": {
        "robot": {"look": {"height": [0.33, 0.33], "tilt_deg": [0, 0], "roll_deg": [0, 0]}}
    },
}
OBJECT_WITH = {"raytraced_share": {"render": {"shader": "raytraced", "raytraced_share": 0.05}}}
OBJECT_SETS = (
    *TRAINING_SETS,
    *(f"c_no_{name}" for name in OBJECT_WITHOUT),
    *(f"c_with_{name}" for name in OBJECT_WITH),
)
SET_LABELS = (
    {"a_flat": "flat", "b_textures_room": "procedural", "c_default": "default"}
    | {
        f"c_no_{name}": f"default, no {name.replace('_', ' ')}"
        for name in (*WITHOUT, *OBJECT_WITHOUT)
    }
    | {f"c_with_{name}": f"default, {name.replace('_', ' ')} 5 %" for name in OBJECT_WITH}
)


def wrist_view(width: int, height: int) -> dict:
    """Every camera at ``width`` x ``height``, the wrist camera on, the arm holding it over the
    tray (the defaults), one view per scene. A path-traced view holds the GIL for its whole
    render (about 24 s on 2 cores; far longer when a run of hours yields the CPU to other work
    at ``nice 19``), so a worker may stay silent for an hour before it is taken for hung."""
    render = {"width": width, "height": height, "views": 1, "shadow_map_size": 512}
    patient = {"worker_timeout_s": 3600.0, "sample_timeout_s": 7200.0}
    return {
        "render": render | {"wrist_camera": True},
        "robot": {"pose": "look"},
        "build": patient,
    }


def wrist_training_sets(width: int, height: int, frames: int) -> dict[str, dict]:
    """``OBJECT_SETS``: the sets of ``variants.training_sets`` and the default set with each of
    ``OBJECT_WITHOUT`` turned off or ``OBJECT_WITH`` added, seen by the wrist camera."""
    sets = training_sets(wrist_view(width, height), frames)
    default = sets["c_default"]
    sets |= {f"c_no_{name}": merged(default, off) for name, off in OBJECT_WITHOUT.items()}
    return sets | {f"c_with_{name}": merged(default, on) for name, on in OBJECT_WITH.items()}


def wrist_test_domains(width: int, height: int, frames: int, raytraced: int) -> dict[str, dict]:
    """The test domains of ``TEST_DOMAINS`` with ``frames`` scenes each (``raytraced`` for the
    path-traced one); a domain of no scenes is left out."""
    default = repo_config("grasp_tabletop.yaml")
    recipe = {"materials": {"texture_families": TRAIN_TEXTURES}, "lighting": TRAIN_LIGHTING}
    counts = {"num_samples": frames, "seed": TEST_SEED}
    base = merged(merged(default, recipe), wrist_view(width, height) | counts)
    held_out_textures = {
        "materials": {"texture_families": HELD_OUT_TEXTURES},
        "photos": {"enabled": False},
    }
    path_traced = {"num_samples": raytraced, "render": {"shader": "raytraced"}}
    domains = {
        "photos": merged(base, held_out_photos(default)),
        "meshes": merged(base, real_meshes()),
        "lighting": merged(base, {"lighting": HELD_OUT_LIGHTING}),
        "textures": merged(base, held_out_textures),
        "raytraced": merged(base, path_traced),
    }
    return {name: data for name, data in domains.items() if data["num_samples"] > 0}
