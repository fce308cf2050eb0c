"""``datagen replay DIR KEY``: rebuild a grasp sample's scene from its stored USD description
(``DIR/usd/KEY.usda``: the randomised values, the settled object poses and the robot's joints)
with the build's config from the manifest, and render it again with SAPIEN: every camera of
the sample (workspace, the extra views of ``render.views`` from their stored camera values,
the wrist camera).

The stage is read as untrusted input (``stored_description``): only a text stage (``#usda``) with
no composition arcs is opened, so no other file is read and usd-core's binary (crate) reader,
which crashes on corrupt files, is never reached; its values must describe the sample (the
randomisation equal to the sample's metadata, finite poses within reach, finite joint
positions). Anything else is a ``DatasetError`` naming the file. A sample whose metadata names
a user's mesh or picture outside the folders of the dataset's config is refused before its scene
is built (``datagen.dataset.assets``): nothing outside them is read.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

import numpy as np

from datagen.config import config_from_dict
from datagen.dataset.loader import DatasetError, read_manifest
from datagen.safe_json import JsonInputError, loads_bounded

MAX_STAGE_BYTES = 16 * 2**20  # datagen's stages are under 1 MiB
MAX_REACH = 100.0  # metres from the world origin: a settled object farther is not the sample's
MAX_JOINTS = 64


def stored_description(
    usd_path: Path, randomisation: dict[str, Any] | None = None
) -> tuple[dict[str, Any], list[dict[str, Any]], list[float]]:
    """(randomised values, settled object poses in instance order, robot joint positions), read
    from the text stage ``usd_path``; DatasetError naming it if it is not a datagen description
    (of the sample whose metadata's ``randomisation`` is given, when it is)."""
    from pxr import Tf

    try:
        return _read_description(Path(usd_path), randomisation)
    except Tf.ErrorException as exc:  # usd-core's errors: a parse error, a bad value type
        raise DatasetError(f"{usd_path}: usd-core cannot read it ({_usd_error(exc)})") from None


def _usd_error(exc: Exception) -> str:
    """The first message of a usd-core error. Its text may quote the file's bytes, and then
    ``str()`` of it raises UnicodeDecodeError."""
    for error in exc.args:
        try:
            message = " ".join(str(error.commentary).split())
        except (AttributeError, UnicodeDecodeError):
            message = "a message quoting bytes that are not UTF-8"
        if message:
            return message if len(message) <= 200 else message[:197] + "..."
    return "no message"


def _read_description(usd_path: Path, randomisation: dict[str, Any] | None):
    from pxr import Sdf, Usd, UsdGeom
    from transforms3d.quaternions import mat2quat

    stage = Usd.Stage.Open(_text_layer(usd_path), Usd.Stage.LoadNone)
    world = stage.GetDefaultPrim()
    if not world or not world.IsValid():
        raise DatasetError(f"{usd_path}: no default prim; expected a datagen description's /World")
    text = world.GetCustomDataByKey("datagen:randomisation")
    if not isinstance(text, str):
        raise DatasetError(f"{usd_path}: {world.GetPath()} has no datagen:randomisation text")
    try:
        params = loads_bounded(text, what=f"{usd_path}: datagen:randomisation")
    except JsonInputError as exc:
        raise DatasetError(str(exc)) from None
    if randomisation is not None and params != randomisation:
        raise DatasetError(
            f"{usd_path}: its datagen:randomisation is not the sample's (it differs from the "
            "'randomisation' of the sample's metadata)"
        )
    if not isinstance(params, dict) or not isinstance(params.get("objects"), list):
        raise DatasetError(f"{usd_path}: datagen:randomisation has no 'objects' list")
    poses = []
    for k in range(1, len(params["objects"]) + 1):
        prim = stage.GetPrimAtPath(Sdf.Path(f"/World/Objects/object_{k}"))
        if not prim.IsValid():
            raise DatasetError(f"{usd_path}: no /World/Objects/object_{k}")
        matrix = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0), float).T
        if not np.isfinite(matrix).all() or np.abs(matrix[:3, 3]).max() > MAX_REACH:
            raise DatasetError(
                f"{usd_path}: /World/Objects/object_{k}: expected a finite pose within "
                f"{MAX_REACH:g} m of the origin, got translation {matrix[:3, 3].tolist()}"
            )
        poses.append(
            {"position": matrix[:3, 3].tolist(), "quat_wxyz": mat2quat(matrix[:3, :3]).tolist()}
        )
    robot = stage.GetPrimAtPath(Sdf.Path("/World/Robot"))
    return params, poses, _joint_positions(usd_path, robot)


def _text_layer(usd_path: Path):
    """The root layer of a text stage with nothing to compose from other files."""
    from pxr import Sdf

    try:  # non-blocking: a FIFO under the stage's name must not hang replay
        fd = os.open(usd_path, os.O_RDONLY | os.O_NONBLOCK)
        try:
            info = os.fstat(fd)
            regular = stat.S_ISREG(info.st_mode)
            size, head = (info.st_size, os.read(fd, 6)) if regular else (None, b"")
        finally:
            os.close(fd)
    except OSError as exc:
        raise DatasetError(f"{usd_path}: cannot read it ({exc.strerror})") from None
    if size is None or size > MAX_STAGE_BYTES or head != b"#usda ":
        raise DatasetError(
            f"{usd_path}: expected a text USD stage ('#usda' header, at most "
            f"{MAX_STAGE_BYTES // 2**20} MiB) as 'datagen export --to usd' writes, got "
            + ("no regular file" if size is None else f"{size} bytes starting {head!r}")
        )
    layer = Sdf.Layer.FindOrOpen(str(usd_path))
    if layer is None:
        raise DatasetError(f"{usd_path}: usd-core cannot open it")
    others = sorted(layer.GetCompositionAssetDependencies()) + _value_clips(layer)
    if others:
        raise DatasetError(
            f"{usd_path}: it refers to other files ({', '.join(others)[:200]}); a datagen "
            "description is one self-contained stage"
        )
    return layer


def _value_clips(layer) -> list[str]:
    """The specs with value clips: usd-core opens their files as soon as the stage is opened."""
    from pxr import Sdf

    found = []

    def visit(path) -> None:
        spec = layer.GetObjectAtPath(path)
        if spec is not None and "clips" in spec.ListInfoKeys():
            found.append(f"value clips on {path}")

    layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return found


def _joint_positions(usd_path: Path, robot) -> list[float]:
    value = robot.GetCustomDataByKey("datagen:qpos") if robot.IsValid() else None
    try:
        qpos = np.asarray(list(value), dtype=float) if value is not None else np.empty(0)
    except (TypeError, ValueError):
        qpos = np.empty(0)
    if not 1 <= qpos.size <= MAX_JOINTS or qpos.ndim != 1 or not np.isfinite(qpos).all():
        raise DatasetError(
            f"{usd_path}: /World/Robot: expected datagen:qpos, up to {MAX_JOINTS} finite joint "
            "positions"
        )
    return qpos.tolist()


REPLAYABLE_WORLDS = ("tabletop",)  # the scenes replay can rebuild: grasp samples and attempts


def refusal(root: str | Path) -> str | None:
    """Why ``replay`` cannot re-render the samples of the dataset in ``root``, or None."""
    from datagen.registries import FAMILIES

    scene = read_manifest(root).get("scene")
    family = FAMILIES.get(scene) if isinstance(scene, str) else None
    if family is None or family.world in REPLAYABLE_WORLDS:
        return None
    return (
        f"{root}: replay re-renders grasp samples only (scenes of the "
        f"{' or '.join(REPLAYABLE_WORLDS)} world); this dataset's scene is {scene!r}"
    )


def replay(root: str | Path, key: str) -> dict[str, np.ndarray]:
    """RGB image (H, W, 3) per camera of the replayed scene."""
    from datagen.dataset.assets import check_asset_paths
    from datagen.dataset.loader import load
    from datagen.families.grasp_tabletop.world import construct_scene
    from datagen.scene_values.bundles import tabletop_values
    from datagen.sensing.render import capture, keep_renderer_alive
    from datagen.tools.sample_checks import read_metadata

    root = Path(root)
    manifest = read_manifest(root)
    if reason := refusal(root):
        raise DatasetError(reason)
    usd_path = root / "usd" / f"{key}.usda"
    if not usd_path.exists():
        raise DatasetError(
            f"{usd_path} does not exist: add 'usd' to output.formats, or run "
            f"'datagen export {root} --to usd' first"
        )
    config = config_from_dict(manifest["config"], source=str(root / "manifest.json"))
    dataset = load(root)
    meta = read_metadata(dataset, dataset.keys.index(key))
    if not isinstance(meta.get("randomisation"), dict):
        raise DatasetError(f"{root}: sample {key}'s metadata has no 'randomisation' record")
    try:  # the users' meshes and pictures it names: only from the config's folders
        check_asset_paths(meta, manifest, root)
    except DatasetError as exc:
        raise DatasetError(f"{root}: sample {key}: {exc}") from None
    params, poses, qpos = stored_description(usd_path, meta["randomisation"])
    keep_renderer_alive()
    values = tabletop_values(params, f"{usd_path}: datagen:randomisation")  # checked, typed
    scene = construct_scene(config, values | {"drop_poses": poses})
    if len(qpos) != scene.robot.dof:
        raise DatasetError(
            f"{usd_path}: /World/Robot: {len(qpos)} joint positions, the robot has {scene.robot.dof}"
        )
    scene.robot.set_qpos(np.asarray(qpos, np.float32))
    scene.scene.update_render()
    return {name: capture(camera).rgb for name, camera in scene.cameras.items()}


def replay_differences(
    root: str | Path, key: str
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Replays sample ``key``: per camera (workspace, view1, ..., wrist), its stored RGB image,
    the replayed one and their largest per-channel difference per pixel (H, W) int."""
    from datagen.dataset.loader import load
    from datagen.dataset.views import camera_order
    from datagen.sensing.view_effects import stored_colour
    from datagen.tools.sample_checks import read_item

    dataset = load(root)
    item = read_item(dataset, dataset.keys.index(key))
    # the pinhole renders, through each view's stored lens and camera effects
    replayed = {
        name: stored_colour(rgb, item["meta"]["views"][name])
        for name, rgb in replay(root, key).items()
    }
    differences = {}
    for name in sorted(replayed, key=camera_order):
        stored = item["rgb"] if name == "workspace" else item["views"][name]["rgb"]
        diff = np.abs(stored.astype(int) - replayed[name].astype(int)).max(axis=2)
        differences[name] = (stored, replayed[name], diff)
    return differences


def comparison_report(
    key: str, differences: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> tuple[list[str], np.ndarray]:
    """One line per camera and a BGR picture with a row per camera: stored | replayed |
    difference (x8)."""
    import cv2

    lines, rows = [], []
    for name, (stored, replayed, diff) in differences.items():
        label = key if name == "workspace" else f"{key} {name}"
        lines.append(
            f"replayed {label}: {float((diff == 0).mean()):.2%} of pixels identical, "
            f"mean difference {diff.mean():.3f}, largest {diff.max()} (0-255)"
        )
        heat = cv2.applyColorMap(np.clip(diff * 8, 0, 255).astype(np.uint8), cv2.COLORMAP_INFERNO)
        rows.append(
            np.hstack([*(cv2.cvtColor(a, cv2.COLOR_RGB2BGR) for a in (stored, replayed)), heat])
        )
    return lines, np.vstack(rows)
