"""The single frames of navigation and aerial episodes as one flat map-style dataset
(:func:`load_frames`), each frame read and decoded alone from its episode's shard member."""

from __future__ import annotations

import functools
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from datagen.dataset.episode_parts import CAMERA_FRAME_PART, FRAME_PART, imu_for_frame
from datagen.dataset.loader import ShardDataset
from datagen.dataset.manifest import DatasetError
from datagen.dataset.part_rules import IMAGE_PARTS
from datagen.dataset.parts import decode_parts
from datagen.records import SampleMetadata


class FrameDataset:
    """Map-style dataset of the single frames of episodes, in (episode, camera, frame) order: a
    navigation episode's one camera, an aerial episode's every camera (``d0``, ``d0_down``, ...).

    Item: rgb, depth, seg, semantic (aerial: ``flow`` and ``flow_valid`` but on the last frame),
    ``meta`` (the frame's record: poses, commands or agent states, goal, ...), ``camera`` (the
    camera's record, its extrinsics at this frame), ``episode`` (its key), ``frame`` (its
    number), ``view`` (the camera's name; "" for navigation), aerial ``imu`` (its drone's samples
    since the previous frame, :func:`~datagen.dataset.episode_parts.imu_for_frame`) and ``key``
    (``<episode>/f<frame>`` or ``<episode>/f<frame>.<camera>``). Only the frame's own images are
    read and decoded."""

    def __init__(self, root: str | Path, verify: bool = False):
        self.episodes = ShardDataset(root, verify)
        self.index: list[tuple[int, int, str]] = []
        for i in range(len(self.episodes)):
            frames = set()
            for part in self.episodes.part_names(i):
                if m := FRAME_PART.fullmatch(part):
                    frames.add(("", int(m[1])))
                elif m := CAMERA_FRAME_PART.fullmatch(part):
                    frames.add((m[2], int(m[1])))
            self.index.extend((i, k, camera) for camera, k in sorted(frames))
        if len(self.episodes) and not self.index:
            raise DatasetError(
                f"{root}: no episode frames (fNNNN.*.png parts); not navigation or aerial data"
            )

    def __len__(self) -> int:
        return len(self.index)

    @functools.lru_cache(maxsize=8)  # noqa: B019 - a handful of episodes' JSON, per process
    def _episode_meta(self, i: int) -> SampleMetadata:
        return self.episodes.metadata(i)

    def __getitem__(self, j: int) -> dict[str, Any]:
        i, k, view = self.index[j]
        prefix = f"f{k:04d}." + (f"{view}." if view else "")
        names = {prefix + name for name in [*IMAGE_PARTS, "flow.png"]}
        raw = self.episodes.raw(i, names & set(self.episodes.part_names(i)))
        item = decode_parts(
            {name[len(prefix) :]: data for name, data in raw.items() if name != prefix + "flow.png"}
        )
        meta = self._episode_meta(i)
        record = meta["frames"][k]
        if view:
            if prefix + "flow.png" in raw:
                flow = decode_parts({f"f0000.{view}.flow.png": raw[prefix + "flow.png"]})
                item |= {n: flow["frames"][0]["cameras"][view][n] for n in ("flow", "flow_valid")}
            camera = meta["cameras"][view] | record["cameras"][view]
            item["imu"] = imu_for_frame(self.episodes, i, meta, view, k)
        else:
            camera = meta["camera"]
        key = f"{self.episodes.keys[i]}/f{k:04d}" + (f".{view}" if view else "")
        item.update(
            meta=record, camera=camera, episode=self.episodes.keys[i], frame=k, view=view, key=key
        )
        return item

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for j in range(len(self)):
            yield self[j]


def load_frames(root: str | Path, verify: bool = False) -> FrameDataset:
    """The frames of a navigation or aerial dataset as one flat map-style dataset
    (``verify``: as in ``load``)."""
    return FrameDataset(root, verify)
