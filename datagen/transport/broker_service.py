"""A long-lived broker in the foreground (``datagen broker``): runs until SIGINT/SIGTERM, then
stops Mosquitto cleanly so it saves its state. Deployment: docs/deployment.md."""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable

from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import BrokerError, ManagedBroker


def run_broker_forever(
    settings: BrokerSettings,
    *,
    on_ready: Callable[[ManagedBroker], None] | None = None,
    stop: threading.Event | None = None,
) -> int:
    """Runs Mosquitto with ``settings`` (``broker_settings.service_settings`` makes a
    long-lived broker's) until SIGINT/SIGTERM (or ``stop`` is set), then stops it cleanly;
    returns 0. Raises BrokerError if Mosquitto fails to start or dies. ``on_ready(broker)``
    runs once it accepts connections: ``broker.public_url`` is what clients use. Prints
    nothing; logs via ``logging``."""
    stop = stop or threading.Event()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, lambda *_: stop.set())
    try:
        with ManagedBroker(settings) as broker:
            if on_ready is not None:
                on_ready(broker)
            while not stop.wait(0.5):
                if not broker.running:
                    raise BrokerError(f"mosquitto died; log tail:\n{broker.log_tail()}")
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
