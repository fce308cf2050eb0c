"""A surface's look as a typed value: base colour, roughness, metallic and, when textured, the
texture's stored values (a procedural tile of :mod:`datagen.assets.texture_tiles`, or a picture
from a folder). The worlds realise it as a SAPIEN render material
(:func:`datagen.worlds.surfaces.render_material`), the USD export as a UsdPreviewSurface look
(:func:`datagen.exports.usd_looks.material`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from datagen.scene_values.checks import SceneValueError, fields, number, vector

MAX_TEXTURE_KEYS = 64  # a texture's stored values are a flat object of a few named fields


@dataclass(frozen=True)
class Material:
    """``base_color``: linear RGBA, each in [0, 1]; ``roughness`` and ``metallic`` in [0, 1];
    ``texture``: the texture's stored values (their ``family`` names the kind), or None."""

    base_color: tuple[float, ...]
    roughness: float
    metallic: float
    texture: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        for i, channel in enumerate(vector("material.base_color", self.base_color, 4)):
            number(f"material.base_color[{i}]", channel, 0.0, 1.0)
        number("material.roughness", self.roughness, 0.0, 1.0)
        number("material.metallic", self.metallic, 0.0, 1.0)
        if self.texture is not None:
            _texture("material.texture", self.texture)

    @property
    def textured(self) -> bool:
        return self.texture is not None

    def with_texture(self, texture: dict[str, Any]) -> Material:
        return replace(self, texture=texture)

    def to_json(self) -> dict[str, Any]:
        stored: dict[str, Any] = {
            "base_color": list(self.base_color),
            "roughness": self.roughness,
            "metallic": self.metallic,
        }
        return stored if self.texture is None else stored | {"texture": self.texture}

    @classmethod
    def from_json(cls, stored: Any, where: str = "material") -> Material:
        f = fields(where, stored, {"base_color", "roughness", "metallic"}, {"texture"})
        base_color = vector(f"{where}.base_color", f["base_color"], 4)
        for i, channel in enumerate(base_color):
            number(f"{where}.base_color[{i}]", channel, 0.0, 1.0)
        texture = f.get("texture")
        return cls(
            base_color=base_color,
            roughness=number(f"{where}.roughness", f["roughness"], 0.0, 1.0),
            metallic=number(f"{where}.metallic", f["metallic"], 0.0, 1.0),
            texture=None if texture is None else _texture(f"{where}.texture", texture),
        )


def _texture(where: str, texture: Any) -> dict[str, Any]:
    """A texture's stored values: an object naming its ``family``; the values themselves are
    checked where a tile or picture is made of them."""
    if not isinstance(texture, dict) or len(texture) > MAX_TEXTURE_KEYS:
        raise SceneValueError(f"{where}: expected an object of at most {MAX_TEXTURE_KEYS} keys")
    if not isinstance(texture.get("family"), str):
        raise SceneValueError(f"{where}.family: expected the texture's family, a string")
    return texture
