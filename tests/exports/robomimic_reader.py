"""Run in the readers' environment: reads a robomimic export with robomimic 0.3.0's own code, as
its train.py does: ``FileUtils.get_env_metadata_from_dataset``, ``EnvUtils.get_env_type``,
``FileUtils.get_shape_metadata_from_dataset`` and a ``SequenceDataset`` over the ``train`` mask
(low-dim observations cached, images read from the file). Prints what it read as JSON and saves
the sequences it fetched as ``OUT/<index>.npz``. Usage: python robomimic_reader.py HDF5 OUT."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import h5py
import numpy as np
import robomimic.envs.env_base as EB
import robomimic.utils.env_utils as EnvUtils
import robomimic.utils.file_utils as FileUtils
import robomimic.utils.obs_utils as ObsUtils
from robomimic.utils.dataset import SequenceDataset

SEQ = 4  # frames per fetched sequence (padded past a demo's end, as robomimic trains)


def _modalities(path: str) -> dict[str, list[str]]:
    """The observation keys by robomimic modality, from the first demo's ``obs``."""
    with h5py.File(path, "r") as f:
        obs = f["data"][sorted(f["data"])[0]]["obs"]
        keys = sorted(obs)
    return {
        "rgb": [k for k in keys if k.endswith("_image")],
        "depth": [k for k in keys if k.endswith("_depth")],
        "low_dim": [k for k in keys if not k.endswith(("_image", "_depth"))],
    }


def main(path: str, out: Path) -> None:
    env_meta = FileUtils.get_env_metadata_from_dataset(dataset_path=path)
    env_type = EnvUtils.get_env_type(env_meta=env_meta)
    modalities = _modalities(path)
    ObsUtils.initialize_obs_utils_with_obs_specs({"obs": modalities})
    keys = [k for keys in modalities.values() for k in keys]
    shape_meta = FileUtils.get_shape_metadata_from_dataset(path, all_obs_keys=keys)
    dataset = SequenceDataset(
        hdf5_path=path,
        obs_keys=keys,
        dataset_keys=("actions", "rewards", "dones"),
        seq_length=SEQ,
        hdf5_cache_mode="low_dim",
        filter_by_attribute="train",
    )
    picks = sorted({0, len(dataset) // 2, len(dataset) - 1})
    for index in picks:
        item = dataset[index]
        arrays = {f"obs/{k}": v for k, v in item["obs"].items()}
        arrays |= {k: item[k] for k in ("actions", "rewards", "dones")}
        np.savez(out / f"{index}.npz", **arrays)
    print(
        json.dumps(
            {
                "env_meta": env_meta,
                "env_type": env_type,
                "gym": env_type == EB.EnvType.GYM_TYPE,
                "robosuite": EnvUtils.is_robosuite_env(env_meta=env_meta),
                "ac_dim": shape_meta["ac_dim"],
                "use_images": shape_meta["use_images"],
                "shapes": {k: list(v) for k, v in shape_meta["all_shapes"].items()},
                "demos": [str(d) for d in dataset.demos],
                "length": len(dataset),
                "picks": picks,
            }
        )
    )


if __name__ == "__main__":
    main(sys.argv[1], Path(sys.argv[2]))
