"""``datagen replay DIR KEY``: rebuild a grasp sample's scene from its stored USD description
(``DIR/usd/KEY.usda``: the randomised values, the settled object poses and the robot's joints)
with the build's config from the manifest, and render it again with SAPIEN: every camera of
the sample (workspace, the extra views of ``render.views`` from their stored camera values,
the wrist camera)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from datagen.config import config_from_dict
from datagen.dataset.loader import DatasetError, read_manifest


def stored_description(usd_path: Path) -> tuple[dict[str, Any], list[dict[str, Any]], list[float]]:
    """(randomised values, settled object poses in instance order, robot joint positions)."""
    from pxr import Usd, UsdGeom
    from transforms3d.quaternions import mat2quat

    stage = Usd.Stage.Open(str(usd_path))
    params = json.loads(stage.GetDefaultPrim().GetCustomDataByKey("datagen:randomisation"))
    poses = []
    for k in range(1, len(params["objects"]) + 1):
        prim = stage.GetPrimAtPath(f"/World/Objects/object_{k}")
        if not prim.IsValid():
            raise DatasetError(f"{usd_path}: no /World/Objects/object_{k}")
        matrix = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0)).T
        poses.append({"position": matrix[:3, 3].tolist(), "quat_wxyz": mat2quat(matrix[:3, :3]).tolist()})  # fmt: skip
    qpos = list(stage.GetPrimAtPath("/World/Robot").GetCustomDataByKey("datagen:qpos"))
    return params, poses, qpos


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
    from datagen.engines.sim.render import capture, keep_renderer_alive
    from datagen.worlds.tabletop import construct_scene

    root = Path(root)
    manifest = read_manifest(root)
    if reason := refusal(root):
        raise DatasetError(reason)
    usd_path = root / "usd" / f"{key}.usda"
    if not usd_path.is_file():
        raise DatasetError(
            f"{usd_path} does not exist: add 'usd' to output.sinks, or run "
            f"'datagen export {root} --to usd' first"
        )
    config = config_from_dict(manifest["config"], source=str(root / "manifest.json"))
    params, poses, qpos = stored_description(usd_path)
    keep_renderer_alive()
    scene = construct_scene(config, params | {"drop_poses": poses})
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
    from datagen.engines.sim.view_effects import stored_colour

    dataset = load(root)
    item = dataset[dataset.keys.index(key)]
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
        rows.append(np.hstack([*(cv2.cvtColor(a, cv2.COLOR_RGB2BGR) for a in (stored, replayed)), heat]))  # fmt: skip
    return lines, np.vstack(rows)
