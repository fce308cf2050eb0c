"""The labelled camera views inside a sample, whatever its scene family: the stored metadata's
``format`` (``datagen.formats``) says how the sample describes its views, and
:func:`labelled_views` turns each shape into one list of :class:`LabelledView`. The shapes the
built-in formats use:

``datagen.sample/1``: one view per camera in ``views`` (the workspace camera's images are the
unprefixed parts, another camera's are prefixed by its name: ``view1.rgb.png``, ``wrist.rgb.png``;
``render.views`` > 1 adds ``view1``, ``view2``, ...), in the order workspace, view1, view2, ...,
then any other camera by name.
``datagen.nav_episode/1``: a time sequence, one view per record in ``frames`` (parts
``f0003.rgb.png``, ...), all seen by the one camera in ``camera``.
``datagen.aerial_episode/1`` and ``datagen.nav_fleet/1``: a time sequence per camera
(``cameras``: ``d0``, ``d0_down``, ``d1``, ... for drones, ``r0``, ``r1``, ... for ground robots),
one view per frame and camera (parts ``f0003.d0.rgb.png``, ...), camera by camera.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from datagen.records import CameraRecord, FrameRecord, LabelledInstance, SampleMetadata, ViewRecord
from datagen.registries import metadata_format

# Classes that are surfaces, not countable instances: left out of instance annotations. The
# robot's arm and gripper are instances (a sample view's ``robot_parts``).
STUFF = frozenset({"background", "floor", "wall", "table", "tray"})


@dataclass
class LabelledView:
    name: str  # "" for a sample's main (workspace) camera, else "wrist", "f0003", ...
    prefix: str  # part-name prefix of its images: "" or "wrist." or "f0003."
    instances: list[LabelledInstance]
    camera: CameraRecord  # with this view's extrinsics_world_to_camera
    record: ViewRecord | FrameRecord  # its own metadata record (a frame's)
    time_index: int | None = None  # a sequence's frame number; None for a camera of a sample
    sequence: str = ""  # the camera of a sequence with several ("d0", "d1_down"); "" with one


def camera_views(meta: SampleMetadata) -> Iterator[LabelledView]:
    """``datagen.sample/1``: one view per camera, in :func:`camera_order`."""
    for name in sorted(meta["views"], key=camera_order):
        view = meta["views"][name]
        instances: list[LabelledInstance] = [
            {
                "instance_id": o["instance_id"],
                "class": o["class"],
                "bbox_xyxy": o["bbox_xyxy"],  # type: ignore[typeddict-item]  # visible: a box
                "visible_fraction": o["visible_fraction"],
            }
            for o in [*view["objects"], *view.get("robot_parts", [])]
            if o["visible"]
        ]
        prefix = "" if name == "workspace" else f"{name}."
        yield LabelledView(
            "" if name == "workspace" else name, prefix, instances, view["camera"], record=view
        )


def camera_order(name: str) -> tuple[int, int, str]:
    """Sort key of a sample's cameras: workspace, view1, view2, ..., view10, ..., then others."""
    if name == "workspace":
        return (0, 0, "")
    if name.startswith("view") and name[4:].isdigit():
        return (1, int(name[4:]), "")
    return (2, 0, name)


def sequence_views(meta: SampleMetadata) -> Iterator[LabelledView]:
    """``datagen.nav_episode/1``: one view per frame, in time order, of the shared camera."""
    for record in meta["frames"]:
        name = f"f{record['frame']:04d}"
        camera = meta["camera"] | {
            "extrinsics_world_to_camera": record["extrinsics_world_to_camera"]
        }
        yield LabelledView(
            name, f"{name}.", list(record["things"]), camera, record, record["frame"]
        )


def camera_sequence_views(meta: SampleMetadata) -> Iterator[LabelledView]:
    """``datagen.aerial_episode/1``: each camera's frames in time order, camera after camera."""
    for camera in sorted(meta["cameras"]):
        for record in meta["frames"]:
            name = f"f{record['frame']:04d}.{camera}"
            seen = record["cameras"][camera]
            calibration = meta["cameras"][camera] | {
                "extrinsics_world_to_camera": seen["extrinsics_world_to_camera"]
            }
            yield LabelledView(
                name, f"{name}.", list(seen["things"]), calibration, record, record["frame"], camera
            )


def labelled_views(meta: SampleMetadata) -> list[LabelledView]:
    """Every labelled view of one sample, read by its metadata format's ``views``
    (``datagen.formats``; DatasetError for a format not registered)."""
    views = metadata_format(meta, f"sample {meta.get('key')}").function("views")
    return list(views(meta))


def sequences(views: list[LabelledView]) -> dict[str, list[LabelledView]]:
    """A sequence's views by camera (one entry, ``""``, for a sequence with one camera)."""
    out: dict[str, list[LabelledView]] = {}
    for view in views:
        out.setdefault(view.sequence, []).append(view)
    return out


def is_sequence(views: list[LabelledView]) -> bool:
    """Whether the views are the frames of one time sequence (to stack along a time axis)."""
    return bool(views) and all(v.time_index is not None for v in views)


def thing_classes(classes: list[str]) -> dict[str, int]:
    """Countable classes -> their id in the dataset's class list (= the semantic.png value)."""
    return {name: i for i, name in enumerate(classes) if name not in STUFF}
