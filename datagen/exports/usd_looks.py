"""Materials of a USD scene: a UsdPreviewSurface per stored material; a textured one reads its
tile from a PNG beside the stage (``textures/<key>/<look>.png``, written when the stage is
exported) through a UsdUVTexture, whose coordinates are the mesh's ``primvars:st``
(face-varying, the box mapping and scale/rotation the renderer used, so USD shows what SAPIEN
drew). Tiles hold the values the renderer used as linear colour: ``sourceColorSpace`` raw."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import trimesh
from pxr import Gf, Sdf, UsdGeom, UsdShade, Vt

from datagen.assets.texture_tiles import surface_uv, texture_tile
from datagen.assets.uv_mapping import box_mapped
from datagen.exports.files import inside, written
from datagen.scene_values.material import Material


def texture_asset(key: str, look: str) -> str:
    """The tile's path relative to the stage file."""
    return f"./textures/{key}/{look}.png"


def material(
    stage, key: str, name: str, values: Material, out_dir: Path | None
) -> UsdShade.Material:
    """``/World/Looks/<name>``; a textured look's tile is written under ``out_dir`` (the folder
    the stage is exported to) when one is given."""
    look = UsdShade.Material.Define(stage, f"/World/Looks/{name}")
    shader = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    r, g, b = values.base_color[:3]
    diffuse = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    diffuse.Set(Gf.Vec3f(r, g, b))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(values.roughness))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(float(values.metallic))
    look.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    if values.texture is not None:
        asset = texture_asset(key, name)
        if out_dir is not None:
            path = inside(out_dir, asset)  # the key and the look's name come from the sample
            path.parent.mkdir(parents=True, exist_ok=True)
            tile = cv2.cvtColor(texture_tile(values.texture), cv2.COLOR_RGB2BGR)
            written(cv2.imwrite(str(path), tile), path, "OpenCV")
        reader = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/st")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        tile = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/tile")
        tile.CreateIdAttr("UsdUVTexture")
        tile.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(asset)
        tile.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        for wrap in ("wrapS", "wrapT"):
            tile.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("repeat")
        tile.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader.ConnectableAPI(), "result"
        )
        diffuse.ConnectToSource(tile.ConnectableAPI(), "rgb")
        look.GetPrim().SetCustomDataByKey("datagen:texture", values.texture["family"])
    return look


def mesh(
    stage,
    path: str,
    tri: trimesh.Trimesh,
    look: UsdShade.Material,
    values: Material,
    uv_frame: np.ndarray | None = None,
) -> UsdGeom.Mesh:
    """A Mesh prim of ``tri`` bound to ``look``; textured ``values`` add face-varying
    ``primvars:st``, box-mapped in the frame where the renderer mapped them (``uv_frame``:
    the mesh's points are moved by it first; a box drawn about its centre, say)."""
    usd_mesh = UsdGeom.Mesh.Define(stage, path)
    usd_mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, v)) for v in tri.vertices]))
    usd_mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(tri.faces)))
    usd_mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in tri.faces.ravel()]))
    usd_mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    lo, hi = tri.bounds
    usd_mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    UsdShade.MaterialBindingAPI.Apply(usd_mesh.GetPrim()).Bind(look)
    if values.texture is not None:
        mapped = tri if uv_frame is None else tri.copy().apply_transform(uv_frame)
        st = surface_uv(box_mapped(mapped).uv_m, values.texture)
        primvar = UsdGeom.PrimvarsAPI(usd_mesh).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying
        )
        # USD's t runs up the picture, SAPIEN's v down its rows: the same texel at both
        primvar.Set(Vt.Vec2fArray([Gf.Vec2f(float(u), float(-v)) for u, v in st]))
    return usd_mesh
