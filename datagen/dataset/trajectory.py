"""The ``trajectory.npz`` part of a grasp attempt: its execution recorded step by step.

One ``np.savez_compressed`` archive of plain arrays (no pickle; read with
``allow_pickle=False``) plus ``names``, a uint8 array holding UTF-8 JSON: the column names,
the phase names, the rates. Rows are states sampled every ``row_every_steps`` physics steps;
``step_action`` holds the command of every physics step, so replaying it in a fresh scene of the
same (seed, index) gives the same states. Layout: docs/dataset-format.md.
"""

from __future__ import annotations

import io
import json
import zipfile
from typing import Any

import numpy as np

from datagen.dataset.manifest import DatasetError

FORMAT = "datagen.trajectory/1"
PHASES = ("open", "transit", "approach", "close", "lift", "hold")  # phase code = index
CONTACT_NAMES = ("target_left_finger", "target_right_finger", "robot_other_impulse")
# array -> (dtype, trailing shape as names-key or int, "row" | "step" | "frame" | "phase")
ARRAYS: dict[str, tuple[str, str | int | None, str]] = {
    "step": ("int32", None, "row"),  # physics steps done before the row's state
    "time": ("float32", None, "row"),  # s, = step * timestep
    "phase": ("uint8", None, "row"),  # index into names["phases"]
    "qpos": ("float32", "joint_names", "row"),  # rad (revolute) or m (prismatic)
    "qvel": ("float32", "joint_names", "row"),  # rad/s or m/s
    "action": ("float32", "action_names", "row"),  # the command applied from this row's step on
    "gripper_opening": ("float32", None, "row"),  # m, finger gap (sum of the finger joints)
    "tcp_pose": ("float32", 7, "row"),  # world xyz (m) + quaternion wxyz
    "target_pose": ("float32", 7, "row"),  # world xyz (m) + quaternion wxyz
    "contact": ("float32", "contact_names", "row"),  # flags 0/1, impulse N*s
    "step_action": ("float32", "step_action_names", "step"),  # every physics step
    "frame_step": ("int32", None, "frame"),
    "frame_time": ("float32", None, "frame"),  # s
    "phase_start_step": ("int32", len(PHASES), None),  # -1: the phase never began
}
MAX_BYTES = 64 * 2**20  # uncompressed, all arrays together; an attempt holds well under 1 MiB


def encode_trajectory(arrays: dict[str, np.ndarray], names: dict[str, Any]) -> bytes:
    """The part's bytes; ``arrays`` as in ``ARRAYS`` (cast to their dtypes)."""
    out = {key: np.asarray(arrays[key], dtype=ARRAYS[key][0]) for key in ARRAYS}
    text = json.dumps({"format": FORMAT, **names}, sort_keys=True).encode()
    out["names"] = np.frombuffer(text, np.uint8)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **out)
    return buffer.getvalue()


def decode_trajectory(data: bytes) -> dict[str, Any]:
    """The part as a dict of arrays plus ``names`` (a dict); DatasetError naming what is wrong
    (not an archive, a missing or extra array, a wrong dtype or shape, a non-finite value)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            if sum(info.file_size for info in archive.infolist()) > MAX_BYTES:
                raise DatasetError(f"part 'trajectory.npz': over {MAX_BYTES} bytes unpacked")
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            loaded = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise DatasetError(f"part 'trajectory.npz' is not a readable .npz: {exc}") from None
    missing = sorted({*ARRAYS, "names"} - set(loaded))
    extra = sorted(set(loaded) - {*ARRAYS, "names"})
    if missing or extra:
        raise DatasetError(f"part 'trajectory.npz': missing arrays {missing}, unknown {extra}")
    try:
        names = json.loads(loaded.pop("names").astype(np.uint8).tobytes())
    except (ValueError, UnicodeDecodeError):
        names = None
    if not isinstance(names, dict) or names.get("format") != FORMAT:
        raise DatasetError(f"part 'trajectory.npz': 'names' is not {FORMAT} JSON")
    lengths = {"row": len(loaded["step"]), "step": len(loaded["step_action"])}
    lengths["frame"] = len(loaded["frame_step"])
    for key, (dtype, width, along) in ARRAYS.items():
        array = loaded[key]
        size = len(names.get(width, ())) if isinstance(width, str) else width
        shape = ((lengths[along],) if along else ()) + ((size,) if size is not None else ())
        if array.dtype != np.dtype(dtype) or array.shape != shape:
            raise DatasetError(
                f"part 'trajectory.npz': array {key!r} is {array.dtype} {array.shape}, "
                f"expected {dtype} {shape}"
            )
        if array.dtype.kind == "f" and not np.isfinite(array).all():
            raise DatasetError(f"part 'trajectory.npz': array {key!r} holds non-finite values")
    return loaded | {"names": names}
