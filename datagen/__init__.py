"""datagen: synthetic, annotated, reproducible datasets for robot learning.

Loading a dataset needs neither the simulator nor a broker::

    import datagen
    dataset = datagen.load("datasets/grasp_tabletop")
    frames = datagen.load_frames("datasets/nav_rooms")  # navigation: one item per frame
    stream = datagen.stream("datasets/grasp_tabletop", shuffle=True)  # torch IterableDataset
    loader = DataLoader(dataset, batch_size=8, collate_fn=datagen.collate)  # batches of tensors
"""

from datagen.blas_kernel import pin_kernel

pin_kernel()  # before anything loads numpy: the same bytes on every AVX-512 CPU

from datagen.config import BuildConfig, load_config  # noqa: E402
from datagen.dataset.batching import collate  # noqa: E402
from datagen.dataset.frame_dataset import load_frames  # noqa: E402
from datagen.dataset.loader import DatasetError, load, verify  # noqa: E402
from datagen.errors import ConfigError  # noqa: E402

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
