"""A built set's views as a segmentation problem: colour images, a class map over
``SEGMENTATION_CLASSES`` and the map of the grasp targets' instances; saved to and read back
from one ``.npz`` (only numpy and torch needed to read it)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

SEGMENTATION_CLASSES = ("other", "table", "tray", "object")
OTHER = ("background", "floor", "wall", "robot", "gripper", "distractor")


@dataclass
class Frames:
    images: object  # torch uint8 (N, 3, H, W), RGB
    classes: object  # torch int64 (N, H, W): index into SEGMENTATION_CLASSES
    targets: object  # torch int32 (N, H, W): the grasp target's instance id, 0 = none

    def __len__(self) -> int:
        return len(self.images)

    def float_images(self):
        """(N, 3, H, W) float32 in 0..1."""
        return self.images.float() / 255.0


def class_lut(classes: Sequence[str]):
    """Stored semantic id -> index into SEGMENTATION_CLASSES: table and tray are themselves,
    every class of ``OTHER`` is ``other``, every other class (the targets' shapes, or the class
    folders of ``objects.source: folder``) is ``object``."""
    import numpy as np

    lut = np.zeros(256, np.int64)
    for i, name in enumerate(classes):
        if name in ("table", "tray"):
            lut[i] = SEGMENTATION_CLASSES.index(name)
        elif name not in OTHER:
            lut[i] = SEGMENTATION_CLASSES.index("object")
    return lut


def camera_images(item: dict, cameras: Sequence[str] | None) -> Iterator[tuple[str, dict]]:
    """(camera name, its images) of a loaded sample: the named cameras, or every camera
    (workspace, then the others as stored) when ``cameras`` is None."""
    named = {"workspace": item, **item.get("views", {})}
    for name in named if cameras is None else cameras:
        yield name, named[name]


def target_ids(meta: dict, camera: str) -> list[int]:
    return [o["instance_id"] for o in meta["views"][camera]["objects"] if o["role"] == "target"]


def read_frames(
    dataset: Path, size: tuple[int, int], cameras: Sequence[str] | None = None
) -> Frames:
    """Every view of ``cameras`` of every sample, resized to ``size`` (width, height): colour by
    area, the maps by nearest pixel."""
    import cv2
    import numpy as np
    import torch

    import datagen

    lut = class_lut(datagen.dataset.loader.read_manifest(dataset)["classes"])
    images, classes, targets = [], [], []
    for item in datagen.load(dataset):
        for camera, view in camera_images(item, cameras):
            images.append(cv2.resize(view["rgb"], size, interpolation=cv2.INTER_AREA))
            semantic = cv2.resize(view["semantic"], size, interpolation=cv2.INTER_NEAREST)
            classes.append(lut[semantic])
            seg = cv2.resize(view["seg"], size, interpolation=cv2.INTER_NEAREST)
            targets.append(np.where(np.isin(seg, target_ids(item["meta"], camera)), seg, 0))
    return Frames(
        torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).contiguous(),
        torch.from_numpy(np.stack(classes)),
        torch.from_numpy(np.stack(targets).astype(np.int32)),
    )


def save_frames(frames: Frames, path: Path) -> None:
    import numpy as np
    import torch

    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".partial.npz")
    np.savez_compressed(
        partial,
        x=frames.images.numpy(),
        y=frames.classes.to(torch.uint8).numpy(),
        targets=frames.targets.numpy().astype(np.uint16),
    )
    partial.replace(path)


def load_frames(path: Path) -> Frames:
    """Frames saved by ``save_frames``; a file without target maps (saved before they were)
    reads as having no targets."""
    import numpy as np
    import torch

    with np.load(path) as data:
        x = torch.from_numpy(data["x"])
        y = torch.from_numpy(data["y"]).long()
        targets = (
            data["targets"].astype(np.int32) if "targets" in data else np.zeros(y.shape, np.int32)
        )
    return Frames(x, y, torch.from_numpy(targets))
