"""Texture randomiser: which surfaces are textured and with what (stream ``textures``), and the
apply step that turns stored texture values into SAPIEN textures and textured meshes.

The stored values are those of :mod:`datagen.assets.texture_tiles`; a picture from a user's folder is
``{"family": "image", "root", "path", "sha256", "aspect", "scale_m", "rotation_deg"}``.
"""

from __future__ import annotations

import functools
import json
from typing import Any

import numpy as np
import sapien
import trimesh

from datagen.assets.image_library import load_library
from datagen.assets.texture_tiles import (
    IMAGE_FAMILY,
    height_normal_map,
    sample_texture,
    surface_uv,
    texture_tile,
    tile_key,
)
from datagen.assets.uv_mapping import UVMesh, box_mapped
from datagen.config.sections import MaterialsConfig

SURFACES = ("table", "tray", "floor")  # the room's surfaces in materials, after the objects
MIPMAP_LEVELS = 8  # 128 px tiles down to 1 px: far and slanted surfaces are filtered, not aliased


def sample_picture(
    rng: np.random.Generator, root: str, scale_m: tuple[float, float], rotate: bool = True
) -> dict[str, Any]:
    """A picture drawn from a user's folder, as stored texture values."""
    pictures = load_library(root).pictures
    picture = pictures[int(rng.integers(len(pictures)))]
    return {
        "family": IMAGE_FAMILY,
        "root": root,
        "path": picture.path,
        "sha256": picture.sha256,
        "aspect": round(picture.height / picture.width, 6),
        "scale_m": round(float(rng.uniform(*scale_m)), 6),
        "rotation_deg": round(float(rng.uniform(0.0, 360.0)), 6) if rotate else 0.0,
    }


def sample_surface_texture(
    rng: np.random.Generator,
    base_color: list[float],
    cfg: MaterialsConfig,
    pictures_root: str,
    pictures_share: float,
    scale_m: tuple[float, float],
) -> dict[str, Any]:
    """A picture of ``pictures_root`` with probability ``pictures_share`` (when a folder is
    set), else a procedural texture around the surface's colour."""
    use_picture = rng.random() < pictures_share
    if pictures_root and use_picture:
        values = sample_picture(rng, pictures_root, scale_m)
    else:
        values = sample_texture(rng, base_color, cfg.texture_families, scale_m)
    if cfg.normal_maps:
        values["normal_map"] = True
    return values


def add_textures(
    rng: np.random.Generator, cfg: MaterialsConfig, materials: dict[str, Any]
) -> dict[str, Any]:
    """``materials`` (as :func:`sample_materials` drew them) with a ``texture`` on each surface
    drawn to be textured: every object, then table, tray and floor, one draw each, so
    ``texture_probability`` 0 leaves every material exactly as it was."""
    textured = {
        **materials,
        "objects": [dict(m) for m in materials["objects"]],
        **{surface: dict(materials[surface]) for surface in SURFACES},
    }
    for material in [*textured["objects"], *(textured[surface] for surface in SURFACES)]:
        maybe_texture(rng, material, cfg)
    return textured


def maybe_texture(rng: np.random.Generator, material: dict[str, Any], cfg: MaterialsConfig) -> None:
    """Gives ``material`` a ``texture`` with ``materials.texture_probability`` (one draw, then
    the texture's own draws when it is textured)."""
    if rng.random() < cfg.texture_probability:
        material["texture"] = sample_surface_texture(
            rng,
            material["base_color"],
            cfg,
            cfg.textures_dir,
            cfg.textures_dir_share,
            cfg.texture_scale_m,
        )


def texture_surfaces(
    rng: np.random.Generator,
    cfg: MaterialsConfig,
    materials: dict[str, Any],
    names: tuple[str, ...],
) -> dict[str, Any]:
    """``materials`` with a ``texture`` on each of the surfaces ``names`` drawn to be textured
    (one draw each, in order; the navigation scenes' floor, walls and doors)."""
    textured = dict(materials)
    for name in names:
        textured[name] = dict(materials[name])
        if rng.random() < cfg.texture_probability:
            textured[name]["texture"] = sample_surface_texture(
                rng,
                textured[name]["base_color"],
                cfg,
                cfg.textures_dir,
                cfg.textures_dir_share,
                cfg.texture_scale_m,
            )
    return textured


def _rgba(tile: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8: the tile, opaque."""
    rgba = np.full((*tile.shape[:2], 4), 255, np.uint8)
    rgba[..., :3] = tile
    return rgba


def surface_material(values: dict[str, Any]) -> sapien.render.RenderMaterial:
    """Apply step: stored material values (base colour, roughness, metallic, texture if any)
    -> a SAPIEN material."""
    if "texture" in values:
        return textured_material(values)
    return sapien.render.RenderMaterial(
        base_color=values["base_color"], roughness=values["roughness"], metallic=values["metallic"]
    )


def textured_material(values: dict[str, Any]) -> sapien.render.RenderMaterial:
    """A SAPIEN material showing ``values["texture"]`` (the tile is the colour: base colour
    white), with the stored roughness and metallic."""
    texture = values["texture"]
    material = sapien.render.RenderMaterial(
        base_color=[1.0, 1.0, 1.0, 1.0], roughness=values["roughness"], metallic=values["metallic"]
    )
    material.base_color_texture = _render_texture(tile_key(texture), normal_map=False)
    if texture.get("normal_map"):
        material.normal_texture = _render_texture(tile_key(texture), normal_map=True)
    return material


def _render_texture(key: str, normal_map: bool) -> sapien.render.RenderTexture2D:
    """A SAPIEN texture of the tile (made per material: 0.1 ms; the tile itself is cached, and
    a SAPIEN texture must not outlive the render system of the scenes it is used in)."""
    values = json.loads(key)
    tile = height_normal_map(values) if normal_map else texture_tile(values)
    return sapien.render.RenderTexture2D(
        _rgba(tile), "R8G8B8A8Unorm", mipmap_levels=MIPMAP_LEVELS, address_mode="repeat", srgb=False
    )


@functools.lru_cache(maxsize=64)
def _mapped_box(half_size: tuple[float, float, float]) -> UVMesh:
    """A box about its centre with box-mapped coordinates (the table's and tray's repeat)."""
    return box_mapped(trimesh.creation.box(extents=2 * np.asarray(half_size, float)))


def textured_mesh_shape(
    mesh: trimesh.Trimesh | UVMesh,
    values: dict[str, Any],
    material: sapien.render.RenderMaterial | None = None,
) -> sapien.render.RenderShapeTriangleMesh:
    """A render shape of ``mesh`` (in its own frame; or its box mapping) with box-mapped
    texture coordinates and the material of ``values`` (or ``material``, made from them)."""
    mapped = mesh if isinstance(mesh, UVMesh) else box_mapped(mesh)
    return sapien.render.RenderShapeTriangleMesh(
        mapped.vertices,
        mapped.triangles,
        mapped.normals,
        surface_uv(mapped.uv_m, values["texture"]),
        material if material is not None else textured_material(values),
    )


def surface_entity(
    scene: sapien.Scene,
    name: str,
    boxes: list[tuple[Any, Any]],
    values: dict[str, Any],
    collide: bool = True,
) -> sapien.Entity:
    """A static entity of boxes ``(half_size, offset)`` (metres, entity frame at the origin)
    drawn with the textured material ``values``; colliding unless ``collide`` is False."""
    entity = sapien.Entity()
    entity.name = name
    if collide:
        body = sapien.physx.PhysxRigidStaticComponent()
        for half_size, offset in boxes:
            shape = sapien.physx.PhysxCollisionShapeBox(
                np.asarray(half_size, np.float32), sapien.physx.get_default_material()
            )
            shape.local_pose = sapien.Pose(offset)
            body.attach(shape)
        entity.add_component(body)
    material = surface_material(values)
    render_body = sapien.render.RenderBodyComponent()
    for half_size, offset in boxes:
        if "texture" in values:
            box = _mapped_box(tuple(float(h) for h in half_size))
            shape = textured_mesh_shape(box, values, material)
        else:
            shape = sapien.render.RenderShapeBox(np.asarray(half_size, np.float32), material)
        shape.local_pose = sapien.Pose(offset)
        render_body.attach(shape)
    entity.add_component(render_body)
    scene.add_entity(entity)
    return entity
