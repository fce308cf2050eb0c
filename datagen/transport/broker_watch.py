"""Is the broker answering? ``BrokerWatch`` probes it from a thread of its own: every
``interval_s`` it opens an MQTT connection (the build's URL and credentials, TLS included) and
waits for the CONNACK. A broker process that is alive but hung (stopped with SIGSTOP, wedged)
still accepts TCP connections in the kernel, but never answers the CONNECT: only an answer
counts.
"""

from __future__ import annotations

import logging
import threading
import time

from datagen.transport.connection import MqttConnectError, MqttConnection

log = logging.getLogger(__name__)
PROBE_INTERVAL_S = 2.0
PROBE_TIMEOUT_S = 2.0


class BrokerWatch:
    """``silent_s()``: seconds since the broker last answered a probe (0 right after start or
    :meth:`reset`). A context manager; the thread is a daemon and stops on ``close``."""

    def __init__(
        self,
        broker_url: str,
        client_id: str,
        interval_s: float = PROBE_INTERVAL_S,
        timeout_s: float = PROBE_TIMEOUT_S,
    ):
        self._url, self._client_id = broker_url, client_id
        self._interval_s, self._timeout_s = interval_s, timeout_s
        self._lock = threading.Lock()
        self._answered = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="broker-watch", daemon=True)

    def __enter__(self) -> BrokerWatch:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(self._timeout_s + 2.0)

    def silent_s(self) -> float:
        with self._lock:
            return time.monotonic() - self._answered

    def reset(self) -> None:
        """The broker was just (re)started: count its silence from now."""
        with self._lock:
            self._answered = time.monotonic()

    def _run(self) -> None:
        while not self._stop.is_set():
            if self.probe():
                self.reset()
            self._stop.wait(self._interval_s)

    def probe(self) -> bool:
        """One round trip: CONNECT, CONNACK, DISCONNECT."""
        try:
            MqttConnection(self._url, self._client_id, timeout_s=self._timeout_s).close()
            return True
        except (MqttConnectError, OSError) as exc:
            log.debug("broker probe failed: %s", exc)
            return False
