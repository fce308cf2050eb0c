"""Topics of one build, and the messages on them (all QoS 1; see docs/wire-format.md):

- ``datagen/<build_id>/samples``  wire-format samples, workers -> writers; writers share it
  (``$share/datagen-<build_id>/datagen/<build_id>/samples``): each sample goes to one writer
- ``datagen/<build_id>/acks``     ``{"key", "index", "writer"}`` (or ``{"indices": [...],
  "writer"}``) once samples are durable in the build's directory
- ``datagen/<build_id>/control``  ``finalize`` / ``announce`` commands -> every writer
- ``datagen/<build_id>/status/<writer_id>``  each writer's state, retained: ready / sealed /
  prepared / finalized / error / stopped / lost

For people watching (``datagen monitor``), plain, unsigned, under ``datagen/<build_id>/live/``
(the broker's ACL alone says who may publish there; docs/monitor.md):

- ``datagen/<build_id>/live/status``  the coordinator's build status JSON, retained, ~1 Hz
- ``datagen/<build_id>/live/preview/<worker>``  a worker's latest annotated JPEG, QoS 0,
  at most one a second per worker
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from datagen.sample import KEY_DIGITS, sample_key, valid_build_id

WRITER_STATES = ("ready", "sealed", "prepared", "finalized", "error", "stopped", "lost")
DEFAULT_FINALIZE_TIMEOUT_S = 300.0


@dataclass(frozen=True)
class Topics:
    build_id: str
    samples: str
    acks: str
    control: str
    status_prefix: str  # + writer id
    shared_samples: str  # what writers subscribe to
    live: str  # everything a monitor may read: live_status and the previews
    live_status: str
    live_preview_prefix: str  # + worker id

    def status(self, writer_id: str) -> str:
        return self.status_prefix + writer_id

    @property
    def status_all(self) -> str:
        return self.status_prefix + "+"

    def live_preview(self, worker_id: str) -> str:
        return self.live_preview_prefix + worker_id

    @property
    def live_preview_all(self) -> str:
        return self.live_preview_prefix + "+"


# Every build's live status on one broker (retained): how a monitor finds the builds.
LIVE_STATUS_ALL_BUILDS = "datagen/+/live/status"


def topics(build_id: str) -> Topics:
    if not valid_build_id(build_id):
        raise ValueError(f"invalid build id {build_id!r}: use 1-64 of [A-Za-z0-9_.-]")
    base = f"datagen/{build_id}"
    return Topics(
        build_id=build_id,
        samples=f"{base}/samples",
        acks=f"{base}/acks",
        control=f"{base}/control",
        status_prefix=f"{base}/status/",
        shared_samples=f"$share/datagen-{build_id}/{base}/samples",
        live=f"{base}/live/#",
        live_status=f"{base}/live/status",
        live_preview_prefix=f"{base}/live/preview/",
    )


def ack_indices(obj: Any) -> list[int] | None:
    """Sample indices of an ack message (``{"key", "index"}`` or ``{"indices": [...]}``);
    None if malformed (a key not matching its index, a negative or non-integer index)."""
    if not isinstance(obj, dict):
        return None
    if "indices" in obj:
        indices = obj["indices"]
        if not isinstance(indices, list) or not all(_is_index(i) for i in indices):
            return None
        return indices
    index = obj.get("index")
    if not _is_index(index):
        return None
    try:
        return [index] if obj.get("key") == sample_key(index) else None
    except ValueError:
        return None


def _is_index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 10**KEY_DIGITS
