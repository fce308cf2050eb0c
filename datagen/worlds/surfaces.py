"""Stored material values made SAPIEN things, in one place: render materials (colour, roughness,
metallic, a texture tile if any), render shapes of meshes and static entities of boxes. The USD
export realises the same values with :mod:`datagen.exports.usd_looks`.

The values are :class:`datagen.scene_values.material.Material` (drawn by
:mod:`datagen.randomisers.materials` and :mod:`datagen.randomisers.textures`); tiles and texture coordinates come from
:mod:`datagen.assets.texture_tiles` and :mod:`datagen.assets.uv_mapping`.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Sequence
from typing import Any

import numpy as np
import sapien
import trimesh

from datagen.assets.texture_tiles import height_normal_map, surface_uv, texture_tile, tile_key
from datagen.assets.uv_mapping import UVMesh, box_mapped
from datagen.scene_values.material import Material

MIPMAP_LEVELS = 8  # 128 px tiles down to 1 px: far and slanted surfaces are filtered, not aliased

Boxes = Sequence[tuple[Any, Any]]  # (half size, centre offset), metres, in the entity's frame


def render_material(material: Material) -> sapien.render.RenderMaterial:
    """A material value (base colour, roughness, metallic, texture if any) as a SAPIEN material.
    A texture maps only onto meshes with texture coordinates (:func:`render_shape`,
    :func:`surface_entity`)."""
    if material.texture is not None:
        return textured_material(material)
    return sapien.render.RenderMaterial(
        base_color=list(material.base_color),
        roughness=material.roughness,
        metallic=material.metallic,
    )


def textured_material(material: Material) -> sapien.render.RenderMaterial:
    """A SAPIEN material showing ``material.texture`` (the tile is the colour: base colour
    white), with the material's roughness and metallic."""
    texture = material.texture
    assert texture is not None  # a textured material
    rendered = sapien.render.RenderMaterial(
        base_color=[1.0, 1.0, 1.0, 1.0], roughness=material.roughness, metallic=material.metallic
    )
    rendered.base_color_texture = _render_texture(tile_key(texture), normal_map=False)
    if texture.get("normal_map"):
        rendered.normal_texture = _render_texture(tile_key(texture), normal_map=True)
    return rendered


def _rgba(tile: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8: the tile, opaque."""
    rgba = np.full((*tile.shape[:2], 4), 255, np.uint8)
    rgba[..., :3] = tile
    return rgba


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
    material: Material,
    rendered: sapien.render.RenderMaterial | None = None,
) -> sapien.render.RenderShapeTriangleMesh:
    """A render shape of ``mesh`` (in its own frame; or its box mapping) with box-mapped
    texture coordinates and ``material`` (``rendered``: the SAPIEN material already made of
    it)."""
    assert material.texture is not None  # a textured material
    mapped = mesh if isinstance(mesh, UVMesh) else box_mapped(mesh)
    return sapien.render.RenderShapeTriangleMesh(
        mapped.vertices,
        mapped.triangles,
        mapped.normals,
        surface_uv(mapped.uv_m, material.texture),
        rendered if rendered is not None else textured_material(material),
    )


def render_shape(mesh: trimesh.Trimesh, material: Material) -> sapien.render.RenderShape:
    """A trimesh as a SAPIEN render shape with its own material: box-mapped texture
    coordinates when the material has a texture, none otherwise (drawn as before textures)."""
    if material.texture is not None:
        return textured_mesh_shape(mesh, material)
    return sapien.render.RenderShapeTriangleMesh(
        np.asarray(mesh.vertices, np.float32),
        np.asarray(mesh.faces, np.uint32),
        np.asarray(mesh.vertex_normals, np.float32),
        np.zeros((len(mesh.vertices), 2), np.float32),
        render_material(material),
    )


def surface_entity(
    scene: sapien.Scene, name: str, boxes: Boxes, material: Material, collide: bool = True
) -> sapien.Entity:
    """A static entity of ``boxes`` (entity frame at the origin) drawn with ``material``,
    textured boxes with their own texture coordinates; colliding unless ``collide`` is
    False."""
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
    rendered = render_material(material)
    render_body = sapien.render.RenderBodyComponent()
    for half_size, offset in boxes:
        if material.texture is not None:
            box = _mapped_box(tuple(float(h) for h in half_size))
            shape = textured_mesh_shape(box, material, rendered)
        else:
            shape = sapien.render.RenderShapeBox(np.asarray(half_size, np.float32), rendered)
        shape.local_pose = sapien.Pose(offset)
        render_body.attach(shape)
    entity.add_component(render_body)
    scene.add_entity(entity)
    return entity


def box_entity(
    scene: sapien.Scene,
    name: str,
    boxes: Boxes,
    material: Material,
    position: Sequence[float] = (0.0, 0.0, 0.0),
    collide: bool = True,
) -> sapien.Entity:
    """A static entity of ``boxes`` at ``position`` (world metres): :func:`surface_entity` when
    textured, else SAPIEN's actor builder (plain boxes, as drawn before textures)."""
    if material.texture is not None:
        entity = surface_entity(scene, name, boxes, material, collide)
    else:
        builder = scene.create_actor_builder()
        rendered = render_material(material)
        for half_size, offset in boxes:
            if collide:
                builder.add_box_collision(sapien.Pose(offset), half_size=half_size)
            builder.add_box_visual(sapien.Pose(offset), half_size=half_size, material=rendered)
        entity = builder.build_static(name=name)
    entity.set_pose(sapien.Pose(position))
    return entity
