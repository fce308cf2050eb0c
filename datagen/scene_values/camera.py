"""A drawn camera pose: where a camera looks from and at, and its vertical field of view."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from datagen.scene_values.checks import fields, number, vector


@dataclass(frozen=True)
class CameraPose:
    """``eye`` and ``target`` (metres, world frame; the camera's up is the world's +z as far as
    it can be), ``fovy_deg`` (vertical field of view); an extra view's ``azimuth_deg``: how far
    its nominal eye was turned about the target's vertical before the jitter."""

    eye: tuple[float, ...]
    target: tuple[float, ...]
    fovy_deg: float
    azimuth_deg: float | None = None

    def __post_init__(self) -> None:
        vector("camera.eye", self.eye)
        vector("camera.target", self.target)
        number("camera.fovy_deg", self.fovy_deg, 0.0, 180.0)
        if self.azimuth_deg is not None:
            number("camera.azimuth_deg", self.azimuth_deg, -360.0, 360.0)

    def to_json(self) -> dict[str, Any]:
        stored: dict[str, Any] = (
            {} if self.azimuth_deg is None else {"azimuth_deg": self.azimuth_deg}
        )
        return stored | {
            "eye": list(self.eye),
            "target": list(self.target),
            "fovy_deg": self.fovy_deg,
        }

    @classmethod
    def from_json(cls, stored: Any, where: str = "randomisation.camera") -> CameraPose:
        f = fields(where, stored, {"eye", "target", "fovy_deg"}, {"azimuth_deg"})
        return cls(
            eye=vector(f"{where}.eye", f["eye"]),
            target=vector(f"{where}.target", f["target"]),
            fovy_deg=number(f"{where}.fovy_deg", f["fovy_deg"], 0.0, 180.0),
            azimuth_deg=f.get("azimuth_deg"),
        )
