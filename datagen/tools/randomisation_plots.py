"""``datagen inspect``'s picture of the appearance randomisation: ``inspect/randomisation.png``.

Counts and histograms of what the samples' metadata says was drawn: texture families per surface,
object and distractor families, room sizes, distractors per scene, which camera effects each view
got and their values, and the depth-sensor model's parameters. A dataset built without a
randomiser (``configs/grasp_flat.yaml``) shows its panel as "not in this dataset".
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypedDict

from datagen.records import SampleMetadata, ViewRecord

CAMERA_EFFECTS = (
    "exposure_ev",
    "white_balance",
    "gamma",
    "noise",
    "motion_blur",
    "defocus_blur",
    "vignetting",
    "jpeg_quality",
    "distortion",
)


def _surfaces(randomisation: dict[str, Any]) -> list[dict[str, Any]]:
    materials = randomisation.get("materials", {})
    surfaces = [m for name, m in materials.items() if name != "objects" and isinstance(m, dict)]
    surfaces += materials.get("objects", [])
    surfaces += list(randomisation.get("background", {}).get("walls", {}).values())
    surfaces += [d["material"] for d in randomisation.get("distractors", []) if "material" in d]
    return surfaces


def _texture_name(material: dict[str, Any]) -> str:
    texture = material.get("texture")
    if texture is None:
        return "flat"
    return texture.get("family", "picture")


def _views(metas: Sequence[SampleMetadata]) -> list[ViewRecord]:
    return [v for m in metas for v in m.get("views", {}).values()]


# panel title -> a Counter (bar chart) or a list of numbers (histogram); empty if absent
Panels = TypedDict(
    "Panels",
    {
        "surface textures": Counter[str],
        "object families": Counter[str],
        "distractors per scene": list[float],
        "room width x (m)": list[float],
        "camera effects (share of views)": Counter[str],
        "exposure (EV)": list[float],
        "lens k1": list[float],
        "depth noise b (1/m)": list[float],
        "projector baseline (m)": list[float],
    },
)


def randomisation_panels(metas: Sequence[SampleMetadata]) -> Panels:
    """The panels of the appearance randomisation plot."""
    randomisations = [m.get("randomisation", {}) for m in metas]
    views = _views(metas)
    effects = [v["camera_effects"] for v in views if "camera_effects" in v]
    sensors = [v["depth_sensor"] for v in views if "depth_sensor" in v]
    rooms = [r["background"]["room"] for r in randomisations if "background" in r]
    return {
        "surface textures": Counter(_texture_name(s) for r in randomisations for s in _surfaces(r)),
        "object families": Counter(
            o["shape"]["family"] for m in metas for o in m.get("objects", [])
        ),
        "distractors per scene": [
            float(len(r["distractors"])) for r in randomisations if "distractors" in r
        ],
        "room width x (m)": [room["x"][1] - room["x"][0] for room in rooms],
        "camera effects (share of views)": Counter(
            {name: sum(name in e for e in effects) / len(effects) for name in CAMERA_EFFECTS}
            if effects
            else {}
        ),
        "exposure (EV)": [e["exposure_ev"] for e in effects if "exposure_ev" in e],
        "lens k1": [e["distortion"][0] for e in effects if "distortion" in e],
        "depth noise b (1/m)": [s["noise_b"] for s in sensors],
        "projector baseline (m)": [s["baseline"] for s in sensors],
    }


def plot_randomisation(metas: list[SampleMetadata], title: str, path: Path) -> None:
    from matplotlib.figure import Figure  # no pyplot: leaves the caller's backend alone

    panels = randomisation_panels(metas)
    fig = Figure(figsize=(13, 10))
    for ax, (name, data) in zip(fig.subplots(3, 3).ravel(), panels.items(), strict=True):
        ax.set_title(name, fontsize=10)
        if not data:
            ax.text(0.5, 0.5, "not in this dataset", ha="center", va="center", color="grey")
            ax.set_xticks([])
            ax.set_yticks([])
        elif isinstance(data, Counter):
            names = sorted(data)
            ax.bar(names, [data[n] for n in names], color="#6a9f58")
            ax.tick_params(axis="x", labelrotation=60, labelsize=8)
        else:
            ax.hist(data, bins=20, color="#4878a8")
    fig.suptitle(f"appearance randomisation, {title}")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
