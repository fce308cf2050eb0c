"""The HDF5 export (docs/hdf5-layout.md) of an aerial build, written by the real command line and
read back with h5py: every modality the family stores is there (issue 39, item 9), checked
against datagen's own loaders: each camera's optical flow and its validity decoded equal to
``datagen.load_frames``' (frame t to t + 1, every frame but the last), its per-frame
``extrinsics_world_to_camera`` equal to the frame's camera record, and nothing ``left_out``."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from conftest import export_copy  # tests/conftest.py: copy a session dataset, export it

import datagen

pytestmark = pytest.mark.sim


def test_aerial_hdf5_holds_flow_extrinsics_and_every_part(aerial_dataset, tmp_path):
    root = tmp_path / "aerial"
    done = export_copy(aerial_dataset, root, "hdf5")
    assert done.returncode == 0, done.stderr[-2000:]
    frames = datagen.load_frames(root)
    seen = {"flow": 0, "last": 0}
    with h5py.File(root / "episodes.h5", "r") as f:
        assert json.loads(f.attrs["left_out"]) == []
        for item in frames:
            group = f[f"samples/{item['episode']}/{item['view']}"]
            k = item["frame"]
            assert group["rgb"].shape[0] == len(group["extrinsics_world_to_camera"])
            extrinsics = np.asarray(item["camera"]["extrinsics_world_to_camera"])
            assert np.array_equal(group["extrinsics_world_to_camera"][k], extrinsics)
            assert np.array_equal(group["rgb"][k], item["rgb"])
            if "flow" in item:
                assert np.array_equal(group["flow"][k], item["flow"])
                assert np.array_equal(group["flow_valid"][k], item["flow_valid"])
                assert item["flow_valid"].any()
                seen["flow"] += 1
            else:  # the last frame has no next one
                assert k == group["rgb"].shape[0] - 1 == group["flow"].shape[0]
                seen["last"] += 1
        for key in f["samples"]:
            assert json.loads(f[f"samples/{key}"].attrs["left_out"]) == []
    assert seen["flow"] > 0 and seen["last"] == 2 * 4  # 2 episodes x 4 cameras
