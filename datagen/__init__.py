"""datagen: synthetic, annotated, reproducible datasets for robot learning.

Loading a dataset needs neither the simulator nor a broker::

    import datagen
    dataset = datagen.load("datasets/grasp_tabletop")
    frames = datagen.load_frames("datasets/nav_rooms")  # navigation: one item per frame
    stream = datagen.stream("datasets/grasp_tabletop", shuffle=True)  # torch IterableDataset
    loader = DataLoader(dataset, batch_size=8, collate_fn=datagen.collate)  # batches of tensors
"""

from datagen.config import BuildConfig, load_config
from datagen.dataset.batching import collate
from datagen.dataset.frame_dataset import load_frames
from datagen.dataset.loader import DatasetError, load, verify
from datagen.errors import ConfigError

__version__ = "0.1.0"


def stream(root, **options):
    """An iterable dataset split across DataLoader workers and nodes (see datagen.dataset.streaming)."""
    from datagen.dataset.streaming import StreamingDataset

    return StreamingDataset(root, **options)


__all__ = [
    "BuildConfig",
    "ConfigError",
    "DatasetError",
    "collate",
    "load",
    "load_config",
    "load_frames",
    "verify",
]
