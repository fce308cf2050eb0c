"""The inspect panels of the appearance randomisation, from metadata alone (pure)."""

from __future__ import annotations

from datagen.tools.randomisation_plots import plot_randomisation, randomisation_panels

TEXTURED = {"base_color": [0.5, 0.5, 0.5, 1], "texture": {"family": "marble"}}
FLAT = {"base_color": [0.5, 0.5, 0.5, 1]}


def _meta(effects: dict, distractors: int) -> dict:
    return {
        "objects": [{"shape": {"family": "mug"}}, {"shape": {"family": "box"}}],
        "randomisation": {
            "materials": {"table": TEXTURED, "floor": FLAT, "objects": [TEXTURED, FLAT]},
            "background": {"room": {"x": [-1.0, 2.0], "y": [-1, 1]}, "walls": {"x_min": FLAT}},
            "distractors": [{"material": TEXTURED}] * distractors,
        },
        "views": {
            "workspace": {
                "camera_effects": effects,
                "depth_sensor": {"noise_b": 0.002, "baseline": 0.05},
            }
        },
    }


def test_panels_count_what_was_drawn():
    metas = [_meta({"exposure_ev": 0.5, "distortion": [-0.1, 0, 0, 0, 0]}, 2), _meta({}, 1)]
    panels = randomisation_panels(metas)
    # per sample: table, distractors (2 or 1) and one object textured; floor, wall, object flat
    assert panels["surface textures"] == {"marble": (1 + 1 + 2) + (1 + 1 + 1), "flat": 6}
    assert panels["object families"] == {"mug": 2, "box": 2}
    assert panels["distractors per scene"] == [2.0, 1.0]
    assert panels["room width x (m)"] == [3.0, 3.0]
    assert panels["camera effects (share of views)"]["exposure_ev"] == 0.5
    assert panels["camera effects (share of views)"]["noise"] == 0.0
    assert panels["lens k1"] == [-0.1]


def test_a_flat_dataset_plots_empty_panels(tmp_path):
    flat = {"objects": [], "randomisation": {"materials": {"table": FLAT}}, "views": {}}
    panels = randomisation_panels([flat])
    assert panels["distractors per scene"] == [] and not panels["camera effects (share of views)"]
    plot_randomisation([flat], "1 samples", tmp_path / "r.png")
    assert (tmp_path / "r.png").stat().st_size > 5_000
