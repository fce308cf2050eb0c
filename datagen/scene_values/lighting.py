"""A scene's lighting as typed values: the ambient level and its lights (a directional key
light, hard- or soft-shadowed; spot fill lights; ceiling point lights), in watts-free units:
colours are linear RGB with the largest channel 1, intensities multiply them."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from datagen.scene_values.checks import (
    SceneValueError,
    choice,
    fields,
    flag,
    number,
    plain,
    vector,
)

LightKind = Literal["directional", "spot", "point"]
LIGHT_KINDS: tuple[LightKind, ...] = ("directional", "spot", "point")
_NEEDS = {"directional": ("direction",), "spot": ("direction", "position", "outer_fov_deg")}
_NEEDS["point"] = ("position",)
_LIGHT_REQUIRED = {"type", "colour", "intensity", "shadow"}
_LIGHT_OPTIONAL = {
    "direction",
    "position",
    "temperature_k",
    "shadow_edge",
    "area_radius_m",
    "outer_fov_deg",
}


@dataclass(frozen=True)
class Light:
    """One light. ``direction``: unit vector it travels along (directional, spot); ``position``
    (metres; spot, point); ``outer_fov_deg``: a spot's cone; ``temperature_k``: the black body
    its colour was drawn from; a directional light's ``shadow_edge`` is ``soft`` from an area
    light of ``area_radius_m`` metres, else hard."""

    kind: LightKind
    colour: tuple[float, ...]
    intensity: float
    shadow: bool
    direction: tuple[float, ...] | None = None
    position: tuple[float, ...] | None = None
    temperature_k: float | None = None
    shadow_edge: Literal["hard", "soft"] | None = None
    area_radius_m: float | None = None
    outer_fov_deg: float | None = None
    where: str = field(default="light", compare=False, repr=False)  # errors name it; not stored

    def __post_init__(self) -> None:
        where = self.where
        choice(f"{where}.type", self.kind, LIGHT_KINDS)
        vector(f"{where}.colour", self.colour)
        number(f"{where}.intensity", self.intensity, 0.0)
        flag(f"{where}.shadow", self.shadow)
        for name in _NEEDS[self.kind]:
            if getattr(self, name) is None:
                raise SceneValueError(f"{where}: a {self.kind} light needs {name}")
        for name in ("direction", "position"):
            if (value := getattr(self, name)) is not None:
                vector(f"{where}.{name}", value)
        if self.temperature_k is not None:
            number(f"{where}.temperature_k", self.temperature_k, 0.0)
        if self.outer_fov_deg is not None:
            number(f"{where}.outer_fov_deg", self.outer_fov_deg, 0.0, 180.0)
        if self.shadow_edge is not None:
            choice(f"{where}.shadow_edge", self.shadow_edge, ("hard", "soft"))
        if self.shadow_edge == "soft":
            number(f"{where}.area_radius_m", self.area_radius_m, 0.0)

    @property
    def soft(self) -> bool:
        return self.shadow_edge == "soft"

    def to_json(self) -> dict[str, Any]:
        stored: dict[str, Any] = {"type": self.kind, "colour": list(self.colour)}
        stored |= {"intensity": self.intensity, "shadow": self.shadow}
        optional = {
            "direction": plain(self.direction),
            "position": plain(self.position),
            "temperature_k": self.temperature_k,
            "shadow_edge": self.shadow_edge,
            "area_radius_m": self.area_radius_m,
            "outer_fov_deg": self.outer_fov_deg,
        }
        return stored | {key: value for key, value in optional.items() if value is not None}

    @classmethod
    def from_json(cls, stored: Any, where: str = "light") -> Light:
        f = fields(where, stored, _LIGHT_REQUIRED, _LIGHT_OPTIONAL)
        return cls(
            kind=f["type"],
            colour=vector(f"{where}.colour", f["colour"]),
            intensity=f["intensity"],
            shadow=f["shadow"],
            direction=_optional_vector(f"{where}.direction", f.get("direction")),
            position=_optional_vector(f"{where}.position", f.get("position")),
            temperature_k=f.get("temperature_k"),
            shadow_edge=f.get("shadow_edge"),
            area_radius_m=f.get("area_radius_m"),
            outer_fov_deg=f.get("outer_fov_deg"),
            where=where,
        )


@dataclass(frozen=True)
class Lighting:
    """The ambient level and the lights. ``target`` (metres): where a spot or point light's
    intensity is what was drawn (radiance is scaled by the squared distance to it; the
    tabletop's tray); ``shadow_centre`` and ``shadow_half_extent`` (metres): the key light's
    shadow volume, when not the world's default; ``shadow_near`` (metres along the light from
    that centre, where shadow casters begin) is set under a room's ceiling and never stored."""

    ambient: float
    lights: tuple[Light, ...]
    target: tuple[float, ...] | None = None
    shadow_centre: tuple[float, ...] | None = None
    shadow_half_extent: float | None = None
    shadow_near: float | None = None

    def __post_init__(self) -> None:
        number("lighting.ambient", self.ambient, 0.0)
        for name in ("target", "shadow_centre"):
            if (value := getattr(self, name)) is not None:
                vector(f"lighting.{name}", value)
        if self.shadow_half_extent is not None:
            number("lighting.shadow_half_extent", self.shadow_half_extent, 0.0)
        aimed = [light for light in self.lights if light.kind == "spot" or light.soft]
        if aimed and self.target is None:
            raise SceneValueError("lighting: spot lights and a soft key light need its target")

    def to_json(self) -> dict[str, Any]:
        stored: dict[str, Any] = {"ambient": self.ambient}
        if self.target is not None:
            stored["target"] = list(self.target)
        stored["lights"] = [light.to_json() for light in self.lights]
        if self.shadow_centre is not None:
            stored["shadow_centre"] = list(self.shadow_centre)
        if self.shadow_half_extent is not None:
            stored["shadow_half_extent"] = self.shadow_half_extent
        return stored

    @classmethod
    def from_json(cls, stored: Any, where: str = "randomisation.lighting") -> Lighting:
        optional = {"target", "shadow_centre", "shadow_half_extent"}
        f = fields(where, stored, {"ambient", "lights"}, optional)
        if not isinstance(f["lights"], list) or len(f["lights"]) > 64:
            raise SceneValueError(f"{where}.lights: expected a list of at most 64 lights")
        lights = tuple(
            Light.from_json(light, f"{where}.lights[{i}]") for i, light in enumerate(f["lights"])
        )
        return cls(
            ambient=f["ambient"],
            lights=lights,
            target=_optional_vector(f"{where}.target", f.get("target")),
            shadow_centre=_optional_vector(f"{where}.shadow_centre", f.get("shadow_centre")),
            shadow_half_extent=f.get("shadow_half_extent"),
        )


def _optional_vector(where: str, value: Any) -> tuple[float, ...] | None:
    return vector(where, value) if value is not None else None
