"""DataTransfer engine: samples out to the broker, acknowledgements and writer status back.

Topics of one build (all QoS 1; see docs/wire-format.md):

- ``datagen/<build_id>/samples``  wire-format samples, workers -> writer
- ``datagen/<build_id>/acks``     ``{"key", "index", "writer"}`` once a sample is durable
- ``datagen/<build_id>/control``  ``{"cmd": "finalize", "expected", "manifest"}`` -> writer
- ``datagen/<build_id>/status``   writer state, retained: ready / finalized / error / stopped / lost
"""

from __future__ import annotations

import collections
import json
import logging
import re
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as mqtt

from datagen.engines.mqtt_client import MqttConnection
from datagen.engines.wire import DEFAULT_MAX_MESSAGE_BYTES, encode_sample
from datagen.sample import Sample, sample_key

log = logging.getLogger(__name__)

_BUILD_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
WRITER_STATES = ("ready", "finalized", "error", "stopped", "lost")


def valid_build_id(build_id: str) -> bool:
    """Build ids go into topics and client ids: no ``/``, ``+``, ``#`` or spaces."""
    return bool(_BUILD_ID.match(build_id))


@dataclass(frozen=True)
class Topics:
    samples: str
    acks: str
    control: str
    status: str


def topics(build_id: str) -> Topics:
    if not valid_build_id(build_id):
        raise ValueError(f"invalid build id {build_id!r}: use 1-64 of [A-Za-z0-9_.-]")
    base = f"datagen/{build_id}"
    return Topics(f"{base}/samples", f"{base}/acks", f"{base}/control", f"{base}/status")


class SampleTooLarge(ValueError):
    """An encoded sample exceeds the broker's message size limit; it was not sent."""


class PublishTimeout(TimeoutError):
    """The broker did not acknowledge a publish in time (broker down or overloaded)."""


class SamplePublisher:
    """QoS 1 publisher with at most ``window`` unacknowledged samples in flight.

    A broker PUBACK only means the broker has the sample (pitfall 2); completion is the
    writer's ack, collected by ``AckCollector``. Never re-publish on a connection error:
    paho resends queued messages after reconnecting (pitfall 7).
    """

    def __init__(
        self,
        broker_url: str,
        build_id: str,
        client_id: str,
        window: int = 8,
        max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
        publish_timeout_s: float = 300.0,
    ):
        if window < 1:
            raise ValueError("window must be >= 1")
        self.build_id = build_id
        self.topic = topics(build_id).samples
        self.window = window
        self.max_message_bytes = max_message_bytes
        self.publish_timeout_s = publish_timeout_s
        self.published = 0
        self._lock = threading.Lock()  # one publish/flush at a time; threads may share us
        self._cond = threading.Condition()
        self._done: set[int] = set()
        self._in_flight: collections.deque[int] = collections.deque()
        self._conn = MqttConnection(broker_url, client_id)
        self._conn.client.on_publish = self._handle_puback

    def __enter__(self) -> SamplePublisher:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:  # already failing: do not wait for PUBACKs on the way out
            self._conn.close()

    def publish(self, sample: Sample) -> None:
        """Encodes and sends one sample; blocks while the in-flight window is full."""
        payload = encode_sample(self.build_id, sample)
        if len(payload) > self.max_message_bytes:
            raise SampleTooLarge(
                f"sample {sample.key} encodes to {len(payload)} bytes, over the "
                f"{self.max_message_bytes}-byte message limit; not published"
            )
        with self._lock:
            while len(self._in_flight) >= self.window:
                self._wait_oldest()
            # During an outage rc is MQTT_ERR_NO_CONN, yet paho keeps the message and sends it
            # after reconnecting; the window wait covers it.
            info = self._conn.client.publish(self.topic, payload, qos=1)
            if info.rc == mqtt.MQTT_ERR_QUEUE_SIZE:
                raise RuntimeError("paho refused the publish: its outgoing queue is full")
            self._in_flight.append(info.mid)
            self.published += 1

    def flush(self) -> None:
        """Waits until the broker acknowledged every sample published so far."""
        with self._lock:
            while self._in_flight:
                self._wait_oldest()

    def close(self) -> None:
        try:
            self.flush()
        finally:
            self._conn.close()

    def _wait_oldest(self) -> None:
        mid = self._in_flight[0]
        deadline = time.monotonic() + self.publish_timeout_s
        with self._cond:
            while mid not in self._done:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise PublishTimeout(
                        f"no PUBACK for a sample within {self.publish_timeout_s} s "
                        f"({len(self._in_flight)} in flight)"
                    )
                self._cond.wait(min(left, 1.0))
            self._done.discard(mid)
        self._in_flight.popleft()

    def _handle_puback(self, client, userdata, mid, reason_code, properties) -> None:
        # 0x10 "no matching subscribers" is a success code: no writer subscribed yet.
        if reason_code.is_failure:
            log.warning("broker refused a sample publish (mid %d): %s", mid, reason_code)
        with self._cond:
            self._done.add(mid)
            self._cond.notify_all()


class AckCollector:
    """Collects writer acks (the set of durable sample indices) and writer status messages.

    Subscribe before any sample is published: acks sent with nobody listening are lost.
    ``on_ack(index)`` and ``on_status(dict)`` run on paho's network thread; keep them short.
    """

    def __init__(
        self,
        broker_url: str,
        build_id: str,
        client_id: str | None = None,
        on_ack: Callable[[int], None] | None = None,
        on_status: Callable[[dict[str, Any]], None] | None = None,
        connect_timeout_s: float = 10.0,
        session_expiry_s: int = 24 * 3600,
    ):
        self.topics = topics(build_id)
        self._on_ack = on_ack
        self._on_status = on_status
        self._cond = threading.Condition()
        self._acked: set[int] = set()
        self._statuses: list[dict[str, Any]] = []
        # Persistent session: acks sent while we are disconnected (broker restart, coordinator
        # restart with the same client id) wait for us instead of being lost.
        self._conn = MqttConnection(
            broker_url,
            client_id or f"datagen-{build_id}-acks",
            subscriptions=[(self.topics.acks, 1), (self.topics.status, 1)],
            on_message=self._handle_message,
            session_expiry_s=session_expiry_s,
            timeout_s=connect_timeout_s,
        )

    def __enter__(self) -> AckCollector:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def acked(self) -> set[int]:
        with self._cond:
            return set(self._acked)

    @property
    def count(self) -> int:
        """Number of distinct acknowledged samples (no copy of the set)."""
        with self._cond:
            return len(self._acked)

    @property
    def statuses(self) -> list[dict[str, Any]]:
        """Every status message received, oldest first (the first may be a retained one)."""
        with self._cond:
            return list(self._statuses)

    def wait_acked(self, indices: Iterable[int] | int, timeout_s: float | None = None) -> bool:
        """Waits until all ``indices`` (or, given an int n, any n samples) are acked."""
        if isinstance(indices, int):
            n = indices

            def done() -> bool:
                return len(self._acked) >= n
        else:
            wanted = set(indices)

            def done() -> bool:
                return wanted <= self._acked

        with self._cond:
            return self._cond.wait_for(done, timeout_s)

    def wait_status(
        self,
        states: str | Iterable[str],
        writer: str | None = None,
        after: int = 0,
        timeout_s: float | None = None,
    ) -> dict[str, Any]:
        """First status message (number ``after`` onwards) in ``states``; TimeoutError if none."""
        wanted = {states} if isinstance(states, str) else set(states)

        def find() -> dict[str, Any] | None:
            for msg in self._statuses[after:]:
                if msg.get("state") in wanted and (writer is None or msg.get("writer") == writer):
                    return msg
            return None

        with self._cond:
            if not self._cond.wait_for(lambda: find() is not None, timeout_s):
                raise TimeoutError(
                    f"no writer status in {sorted(wanted)} within {timeout_s} s; "
                    f"seen: {self._statuses[after:]}"
                )
            return find()  # type: ignore[return-value]

    def finalize(
        self, expected: int, manifest: dict[str, Any], timeout_s: float | None = 60.0
    ) -> dict[str, Any]:
        """Asks the writer to finalize; returns its ``finalized`` or ``error`` status message."""
        with self._cond:
            mark = len(self._statuses)
        cmd = {"cmd": "finalize", "expected": expected, "manifest": manifest}
        self._conn.publish_json(self.topics.control, cmd, qos=1).wait_for_publish(timeout_s)
        return self.wait_status(("finalized", "error"), after=mark, timeout_s=timeout_s)

    def close(self, end_session: bool = True) -> None:
        """``end_session=False`` keeps the broker queueing acks for a later collector."""
        self._conn.close(end_session=end_session)

    def _handle_message(self, message: mqtt.MQTTMessage) -> None:
        try:
            obj = json.loads(message.payload)
        except ValueError:
            log.warning("ignoring non-JSON message on %s", message.topic)
            return
        if message.topic == self.topics.acks:
            self._handle_ack(obj)
        elif message.topic == self.topics.status and isinstance(obj, dict):
            with self._cond:
                self._statuses.append(obj)
                self._cond.notify_all()
            log.info("writer status: %s", obj)
            if self._on_status is not None:
                self._on_status(obj)

    def _handle_ack(self, obj: Any) -> None:
        index = obj.get("index") if isinstance(obj, dict) else None
        if not isinstance(index, int) or isinstance(index, bool) or index < 0:
            log.warning("ignoring malformed ack %r", obj)
            return
        try:
            ok = obj.get("key") == sample_key(index)
        except ValueError:
            ok = False
        if not ok:
            log.warning("ignoring ack whose key does not match its index: %r", obj)
            return
        with self._cond:
            if index in self._acked:
                return
            self._acked.add(index)
            self._cond.notify_all()
        if self._on_ack is not None:
            self._on_ack(index)
