"""The records that cross datagen's boundaries, typed: a sample's stored metadata (its cameras,
objects and boxes), the events a scene worker sends the coordinator, a dataset's manifest and
the signature of an export.

They are TypedDicts: plain dicts at run time (the stored JSON is exactly what was there), keys
and value types for the type checker (``scripts/test.sh`` runs mypy). ``total=False`` records
hold the keys of more than one scene family or format; the keys every record has are
``Required``. The JSON a reader loads is not checked against them: a reader that meets a
dataset it did not write still checks what it reads (``DatasetError``). This module imports
nothing of datagen, so every layer can use it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal, Protocol, Required, TypedDict

Vector = list[float]
Matrix = list[list[float]]  # row-major
BoxXYXY = list[int]  # [x_min, y_min, x_max, y_max] in pixel indices, inclusive
Randomisation = dict[str, Any]  # the drawn values, as each randomiser records them


# --- a sample's metadata (the ``json`` part) ------------------------------------------------------
class PoseRecord(TypedDict):
    matrix: Matrix  # (4, 4)
    position: Vector  # metres
    quat_wxyz: Vector


class ObbRecord(TypedDict):
    pose_world: PoseRecord  # the box's centre and axes
    extents: Vector  # metres, along the box's axes


class CameraRecord(TypedDict, total=False):
    """A camera's intrinsics and placement (OpenCV convention: x right, y down, z forward)."""

    width: Required[int]
    height: Required[int]
    fovy_deg: float
    near: float  # metres
    far: float
    intrinsics: Required[Matrix]  # (3, 3) pixels
    extrinsics_world_to_camera: Matrix  # (4, 4); a sequence has it per frame instead
    convention: str  # "opencv"
    depth_scale: float  # metres per stored depth unit (0.001: millimetres)
    camera_in_robot: Matrix  # (4, 4) a camera riding a robot (navigation)
    height_m: float
    pitch_down_deg: float
    # when camera effects draw a lens: ``intrinsics`` are the distorted image's
    render_intrinsics: Matrix  # (3, 3) the pinhole camera that rendered it
    distortion: Vector  # the drawn k1, k2, p1, p2, k3
    distortion_model: str


ObjectViewRecord = TypedDict(
    "ObjectViewRecord",
    {
        "instance_id": int,
        "class": str,
        "class_id": int,
        "role": str,  # "target" or "distractor"
        "visible": bool,
        "visible_pixels": int,
        "bbox_xyxy": BoxXYXY | None,  # None: no pixel visible
        "visible_fraction": float,  # visible / whole silhouette; 1.0 = fully visible
        "in_frame_fraction": float,
        "pose_camera": PoseRecord,
        "obb_corners_px": Matrix,  # (8, 2) image-plane coordinates
    },
)
"""What one camera sees of one object (``datagen.sensing.annotate``)."""

ObjectWorldRecord = TypedDict(
    "ObjectWorldRecord",
    {
        "instance_id": Required[int],
        "class": Required[str],
        "class_id": Required[int],
        "pose_world": Required[PoseRecord],
        "obb": Required[ObbRecord],
        # physical properties, added by the scene family
        "shape": dict[str, Any],
        "density": float,
        "mass": float,
        "friction": float,
        "restitution": float,
    },
    total=False,
)
"""One object of the scene, in the world frame."""


RobotPartViewRecord = TypedDict(
    "RobotPartViewRecord",
    {
        "instance_id": int,
        "class": str,  # "robot" (the arm) or "gripper"
        "class_id": int,
        "links": list[str],
        "visible": bool,
        "visible_pixels": int,
        "bbox_xyxy": BoxXYXY | None,  # None: no pixel visible
        "visible_fraction": float,
        "in_frame_fraction": float,
    },
)
"""What one camera sees of the robot's arm or gripper (``datagen.sensing.robot_labels``)."""


class ViewRecord(TypedDict, total=False):
    """One camera of a ``datagen.sample/1`` sample: its record and what it sees."""

    camera: Required[CameraRecord]
    objects: Required[list[ObjectViewRecord]]
    robot_parts: list[RobotPartViewRecord]  # the arm, then the gripper (absent before issue 24)
    camera_effects: dict[str, Any]  # the drawn effects, when camera effects are on
    depth_sensor: dict[str, Any]  # the drawn sensor, when a depth sensor is on
    shader: str  # "raytraced" or "rasterized" in builds with render.shader: raytraced


SequenceThing = TypedDict("SequenceThing", {"instance_id": int, "class": str, "name": str})
"""A labelled thing of a sequence's scene (its boxes are in the frames that see it)."""


LabelledInstance = TypedDict(
    "LabelledInstance",
    {
        "instance_id": Required[int],
        "class": Required[str],
        "bbox_xyxy": Required[BoxXYXY],
        "visible_fraction": float,  # a camera's view
        "name": str,  # a sequence's frame
        "pixels": int,
    },
    total=False,
)
"""A labelled instance a view sees (``datagen.dataset.views``): what every family's views share."""


class CameraFrameRecord(TypedDict):
    """What one camera of a ``datagen.aerial_episode/1`` frame saw."""

    extrinsics_world_to_camera: Matrix
    things: list[LabelledInstance]  # those it sees, with their boxes


class FrameRecord(TypedDict, total=False):
    """One frame of a sequence: ``datagen.nav_episode/1`` (its one camera's ``extrinsics`` and
    ``things``, the robot's pose and command) or ``datagen.aerial_episode/1`` (``agents``: each
    drone's state; ``cameras``: what each camera saw)."""

    frame: Required[int]
    step: int
    time_s: float
    pose: Vector  # x, y (metres), yaw (radians)
    command: Vector
    goal_in_robot: Vector
    distance_to_goal: float
    collision: bool
    extrinsics_world_to_camera: Matrix  # navigation
    things: list[LabelledInstance]  # navigation: those the frame sees, with their boxes
    agents: list[dict[str, Any]]  # aerial, fleets: per drone or robot, its state (docs/)
    cameras: dict[str, CameraFrameRecord]  # aerial, fleets: per camera


class ProductionRecord(TypedDict):
    """How a sample was made when it needed more than one attempt (``production``)."""

    attempt: int  # 0 for the first
    failures: list[str]  # why each earlier attempt failed


class SampleMetadata(TypedDict, total=False):
    """A sample's ``json`` part. ``format`` says which of the family-specific keys it has:
    ``datagen.sample/1`` (``objects``, ``views``, and ``attempt`` for a grasp attempt) or
    ``datagen.nav_episode/1`` (``family``, ``things``, ``episode``, ``camera``, ``frames``) or
    ``datagen.aerial_episode/1`` and ``datagen.nav_fleet/1`` (the same, with ``cameras`` for
    ``camera``)."""

    format: Required[str]
    key: Required[str]
    index: Required[int]
    seed: Required[int]
    scene: Required[str]
    classes: Required[list[str]]  # a class's id is its position
    robot: dict[str, Any]
    randomisation: Randomisation
    objects: list[ObjectWorldRecord]
    views: dict[str, ViewRecord]  # camera name -> its view
    attempt: dict[str, Any]  # a grasp attempt: target, grasp, outcome (datagen.families)
    family: str
    things: list[SequenceThing]
    episode: dict[str, Any]  # a navigation episode: success, spl, paths, layout
    camera: CameraRecord
    cameras: dict[str, CameraRecord]  # an aerial episode's cameras (d0, d0_down, ...)
    frames: list[FrameRecord]
    production: ProductionRecord  # only in a sample that needed retries


# --- scene worker -> coordinator -----------------------------------------------------------------
WorkerEventKind = Literal[
    "heartbeat",
    "ready",
    "started",
    "retried",
    "failed",
    "outcome",
    "published",
    "done",
    "error",
    "lost",
]


class AttemptRecord(ProductionRecord):
    """``started`` (an attempt at a sample begins) and ``retried`` (it needed more than one)."""

    index: int


class GivenUpRecord(TypedDict):
    """``failed``: every attempt allowed failed; the worker goes on with its next sample."""

    index: int
    failures: list[str]


class Outcome(TypedDict, total=False):
    """A sample's outcome (``datagen.outcomes``): a grasp attempt's or a navigation episode's."""

    kind: Required[Literal["grasp", "navigation"]]  # navigation: any episode, ground or air
    success: Required[bool]
    sampler: str  # grasp
    family: str  # grasp: the target's class
    failure_mode: str | None  # grasp; None on success
    spl: float  # navigation


class SampleOutcome(Outcome):
    """``outcome``: a sample's outcome and its index, for the live status."""

    index: int


class ProducedRecord(TypedDict, total=False):
    """A Ray worker's answer to one sample, which its executor turns into the same events."""

    index: Required[int]
    failures: Required[list[str]]
    published: Required[bool]  # False: given up
    attempt: int
    outcome: SampleOutcome | None


# heartbeat, ready, done: None; published: the index; error, lost: why
WorkerPayload = AttemptRecord | GivenUpRecord | SampleOutcome | int | str | None
WorkerMessage = tuple[WorkerEventKind, WorkerPayload]  # what a worker sends over its pipe
WorkerEvent = tuple[int, WorkerEventKind, WorkerPayload]  # (worker id, kind, payload), polled


# --- a dataset's manifest and its exports --------------------------------------------------------
class ShardRecord(TypedDict, total=False):
    name: Required[str]  # a file in the dataset directory
    samples: int
    bytes: int
    sha256: str  # of the whole file
    sample_sha256: dict[str, str]  # key -> digest of the sample's parts


class ExportRecord(TypedDict):
    path: str  # in the dataset directory
    bytes: int
    seconds: float


class Manifest(TypedDict, total=False):
    """``manifest.json``: what was built, how, and where it is. Builds and families add keys
    of their own (``versions``, ``campaign``, the assets' and pictures' reports)."""

    dataset_format: str
    build_id: str
    scene: str
    seed: int
    classes: list[str]
    config: dict[str, Any]  # the build's config, as ``BuildConfig.to_dict``
    datagen_version: str
    samples: int
    shards: Required[list[ShardRecord]]
    keys_sha256: str
    exports: dict[str, ExportRecord]  # format name -> where it was written
    campaign: dict[str, Any]


class ExportedDataset(Protocol):
    """What an export reads of a dataset (``datagen.dataset.loader.ShardDataset``)."""

    root: Path
    keys: list[str]
    manifest: Manifest

    def __len__(self) -> int: ...

    def metadata(self, i: int) -> SampleMetadata: ...

    def raw(self, i: int, parts: set[str] | None = None) -> dict[str, bytes]: ...

    def part_names(self, i: int) -> list[str]: ...


SampleProgress = Callable[[int, int], None]  # (samples done, samples in all)


class ExportFunction(Protocol):
    """An export format's ``export``: writes ``out`` (a fresh path) from the dataset's shards,
    calls ``on_progress`` as samples are exported, returns the files written."""

    def __call__(
        self,
        dataset: ExportedDataset,
        manifest: Manifest,
        out: Path,
        on_progress: SampleProgress | None = None,
    ) -> list[Path]: ...
