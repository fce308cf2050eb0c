"""A scene worker process: takes sample indices from a queue, renders them, publishes them."""

from __future__ import annotations

import logging
import os
import signal
import traceback
from typing import Any

from datagen.config import config_from_dict
from datagen.engines.produce import produce_sample
from datagen.engines.transfer import SamplePublisher

log = logging.getLogger(__name__)


def worker_main(
    worker_id: int, config_dict: dict[str, Any], broker_url: str, build_id: str, tasks, events
) -> None:
    """Runs in a spawned process. ``tasks`` yields indices then ``None``; ``events`` receives
    ``("published", worker_id, index)``, ``("done", worker_id, None)`` or ``("error", worker_id, text)``."""
    logging.basicConfig(
        level=os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
        format=f"[worker {worker_id}] %(levelname)s %(message)s",
    )
    # Ctrl-C is the coordinator's to handle: it stops the workers itself, in order
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    index = None
    try:
        config = config_from_dict(config_dict)
        with SamplePublisher(
            broker_url,
            build_id,
            client_id=f"datagen-{build_id}-worker-{worker_id}",
            window=config.transfer.window,
            max_message_bytes=int(config.transfer.max_sample_mb * 2**20),
        ) as publisher:
            while (index := tasks.get()) is not None:
                publisher.publish(produce_sample(config, config.seed, index))
                events.put(("published", worker_id, index))
        events.put(("done", worker_id, None))
    except Exception:
        where = f"sample {index}" if index is not None else "start-up"
        events.put(
            ("error", worker_id, f"worker {worker_id} failed at {where}:\n{traceback.format_exc()}")
        )
        raise SystemExit(1) from None
