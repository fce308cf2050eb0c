"""A grasp model file: ONNX, scored with onnxruntime.

A model file comes from elsewhere, so it is hostile input. ONNX is a graph of standard
operators, not code: nothing is unpickled and no Python runs. The file is read without following
a link, as a regular file of at most ``MODEL_MAX_BYTES``, and handed to onnxruntime as bytes. A
graph that keeps tensors in other files (ONNX external data, which onnxruntime would look for
in the working directory) is refused before onnxruntime sees it, and so are operators from a
domain onnxruntime does not know (no library is loaded for them). The contract (docs/campaigns.md,
"Learning to grasp"):

- input ``crop``: float32 (N, 1, S, S), S fixed in the file between ``MIN_CROP`` and
  ``MAX_CROP`` pixels (``datagen.grasp_model.inputs``);
- input ``grasp``: float32 (N, 14), the candidate's features (same module);
- one output: float32 (N,) or (N, 1), one finite score per candidate, higher = better (datagen's
  own models give the probability of success).

A file that breaks it fails at ``--check`` with one line."""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from datagen.grasp_model.inputs import GRASP_FEATURES
from datagen.images import ImageInputError, read_regular_file

MODEL_MAX_BYTES = 64 * 2**20  # a grasp-quality net is a few MB; this bounds what is decoded
MIN_CROP, MAX_CROP = 8, 256  # pixels a side of the depth crop
CROP_INPUT, GRASP_INPUT = "crop", "grasp"
PROBE_BATCH = 3  # candidates scored once when the file is loaded, to check the output


class ModelFileError(ValueError):
    """A model file that cannot be read or does not keep the contract; the message names it."""


@dataclass(frozen=True)
class GraspModel:
    session: object  # onnxruntime.InferenceSession
    sha256: str
    crop_size: int
    name: str  # the path it was loaded from, for messages (records hold only the sha256)

    def score(self, crops: np.ndarray, features: np.ndarray) -> np.ndarray:
        """(N,) float64 scores of N candidates from ``grasp_batch``'s two arrays."""
        (out,) = self.session.run(  # type: ignore[attr-defined]
            None,
            {
                CROP_INPUT: np.ascontiguousarray(crops, np.float32),
                GRASP_INPUT: np.ascontiguousarray(features, np.float32),
            },
        )
        scores = np.asarray(out, np.float64).reshape(-1)
        if scores.shape != (len(crops),) or not np.all(np.isfinite(scores)):
            raise ModelFileError(
                f"{self.name}: expected one finite score per candidate ({len(crops)}), got "
                f"an output of shape {np.shape(out)}"
                + ("" if np.all(np.isfinite(scores)) else " holding NaN or infinite values")
            )
        return scores


def file_sha256(path: str | os.PathLike[str]) -> str:
    return hashlib.sha256(_read(path)).hexdigest()


def _read(path: str | os.PathLike[str]) -> bytes:
    try:
        return read_regular_file(path, max_bytes=MODEL_MAX_BYTES)
    except ImageInputError as exc:
        raise ModelFileError(str(exc)) from None


def load_model(path: str | os.PathLike[str], sha256: str | None = None) -> GraspModel:
    """The model in ``path``, checked against the contract (and against ``sha256`` if given);
    ModelFileError saying what is wrong otherwise."""
    import onnxruntime

    data = _read(path)
    digest = hashlib.sha256(data).hexdigest()
    if sha256 is not None and digest != sha256:
        raise ModelFileError(
            f"{path}: its sha256 is {digest}, not {sha256} (the file changed since the campaign "
            "started: a campaign's attempts are all scored by one model)"
        )
    _refuse_external_data(data, path)
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1  # one thread: the same scores on every machine and worker
    options.inter_op_num_threads = 1
    options.log_severity_level = 3  # errors only: a refused file is reported below, in one line
    options.add_session_config_entry("session.load_model_format", "ONNX")
    try:
        session = onnxruntime.InferenceSession(data, options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own classes, one per kind of fault
        raise ModelFileError(
            f"{path}: not a usable ONNX model (onnxruntime: {_first_line(exc)})"
        ) from None
    model = GraspModel(session, digest, _crop_size(session, path), str(path))
    _probe(model, path)
    return model


def _refuse_external_data(data: bytes, path) -> None:
    """ModelFileError for a graph whose tensors live in other files: onnxruntime would read
    them from the working directory."""
    import onnx
    from google.protobuf.message import DecodeError

    try:
        proto = onnx.load_model_from_string(data)
    except (DecodeError, ValueError, RuntimeError) as exc:
        raise ModelFileError(f"{path}: not a usable ONNX model (onnx: {exc})"[:400]) from None
    graphs = [proto.graph]
    nodes = [node for function in proto.functions for node in function.node]
    while graphs or nodes:
        if graphs:
            graph = graphs.pop()
            tensors = [*graph.initializer]
            tensors += [
                t for sparse in graph.sparse_initializer for t in (sparse.values, sparse.indices)
            ]
            nodes += graph.node
        else:
            attributes = nodes.pop().attribute
            tensors = [a.t for a in attributes if a.HasField("t")]
            tensors += [t for a in attributes for t in a.tensors]
            graphs += [a.g for a in attributes if a.HasField("g")]
            graphs += [g for a in attributes for g in a.graphs]
        if any(t.data_location == onnx.TensorProto.EXTERNAL for t in tensors):
            raise ModelFileError(
                f"{path}: keeps tensors in other files (ONNX external data): give a model file "
                "that holds all its weights"
            )


def _crop_size(session, path) -> int:
    inputs = {i.name: i for i in session.get_inputs()}
    outputs = session.get_outputs()
    if set(inputs) != {CROP_INPUT, GRASP_INPUT} or len(outputs) != 1:
        raise ModelFileError(
            f"{path}: expected inputs '{CROP_INPUT}' (N, 1, S, S) and '{GRASP_INPUT}' "
            f"(N, {GRASP_FEATURES}) and one output, got inputs {sorted(inputs)} and "
            f"{len(outputs)} outputs"
        )
    for i in inputs.values():
        if i.type != "tensor(float)":
            raise ModelFileError(f"{path}: input '{i.name}': expected float32, got {i.type}")
    crop, grasp = inputs[CROP_INPUT].shape, inputs[GRASP_INPUT].shape
    sides = crop[2:] if len(crop) == 4 else []
    if (
        len(crop) != 4
        or crop[1] != 1
        or len(set(map(str, sides))) != 1
        or not isinstance(sides[0], int)
        or not MIN_CROP <= sides[0] <= MAX_CROP
    ):
        raise ModelFileError(
            f"{path}: input '{CROP_INPUT}': expected shape (N, 1, S, S) with S a fixed number "
            f"of pixels from {MIN_CROP} to {MAX_CROP}, got {crop}"
        )
    if len(grasp) != 2 or grasp[1] != GRASP_FEATURES:
        raise ModelFileError(
            f"{path}: input '{GRASP_INPUT}': expected shape (N, {GRASP_FEATURES}), got {grasp}"
        )
    return int(sides[0])


def _probe(model: GraspModel, path) -> None:
    """Scores a few blank candidates: a graph whose output does not fit fails here, at load."""
    crops = np.zeros((PROBE_BATCH, 1, model.crop_size, model.crop_size), np.float32)
    features = np.zeros((PROBE_BATCH, GRASP_FEATURES), np.float32)
    try:
        model.score(crops, features)
    except ModelFileError:
        raise
    except Exception as exc:  # a graph that fails on a batch of the contract's shape
        raise ModelFileError(
            f"{path}: fails on a batch of the contract's shapes (onnxruntime: {_first_line(exc)})"
        ) from None


def _first_line(exc: Exception) -> str:
    """onnxruntime's message, cut to its first line and 300 characters."""
    text = str(exc).strip()
    return text.splitlines()[0][:300] if text else type(exc).__name__


@lru_cache(maxsize=4)
def cached_model(path: str, sha256: str | None) -> GraspModel:
    """``load_model``, once per process and file: every attempt of a worker scores with it."""
    return load_model(path, sha256)
