"""Samples out to the broker: ``SamplePublisher`` (workers -> ``datagen/<build_id>/samples``).

A broker PUBACK only means the broker has the sample; completion is the writer's ack, collected
by ``collector.AckCollector``. Topic names: ``topics``.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from dataclasses import dataclass

import paho.mqtt.client as mqtt

from datagen.sample import Sample
from datagen.transport.connection import MqttConnection
from datagen.transport.run_binding import RunBinding
from datagen.transport.topics import topics
from datagen.transport.wire import DEFAULT_MAX_MESSAGE_BYTES, encode_sample

log = logging.getLogger(__name__)


class SampleTooLarge(ValueError):
    """An encoded sample exceeds the broker's message size limit; it was not sent."""


class PublishTimeout(TimeoutError):
    """The broker did not acknowledge a publish in time (broker down or overloaded)."""


class PublishRefused(RuntimeError):
    """The broker refused a sample for good (not authorized by its ACL, packet too large...)."""


NO_MATCHING_SUBSCRIBERS = 0x10  # PUBACK reason: the broker dropped the sample, nobody listens
QUOTA_EXCEEDED = 0x97  # PUBACK reason: try again later


@dataclass
class _Sent:
    mid: int
    payload: bytes
    key: str
    first_sent: float
    attempts: int


class SamplePublisher:
    """QoS 1 publisher with at most ``window`` unacknowledged samples in flight.

    A broker PUBACK only means the broker has the sample (docs/mqtt-pitfalls.md, pitfall 2);
    completion is the writer's ack, collected by ``AckCollector``. Never re-publish on a
    connection error: paho resends queued messages after reconnecting (pitfall 7). A PUBACK
    saying "no matching subscribers" means the broker dropped the sample because no writer is
    subscribed (before the first writer, after every writer's session ended, or right after a
    Mosquitto restart, which does not restore shared subscriptions until the writers
    re-subscribe, pitfall 11): such a sample is published again, backing off up to 2 s, for
    at most ``publish_timeout_s``; so is one refused with "quota exceeded". Any other refusal
    (e.g. "not authorized" by the broker's ACL) raises ``PublishRefused``.
    """

    def __init__(
        self,
        broker_url: str,
        build_id: str,
        client_id: str,
        window: int = 8,
        max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
        publish_timeout_s: float = 300.0,
        ca_file: str | None = None,
        secret: bytes | None = None,
        run: RunBinding | None = None,
    ):
        if window < 1:
            raise ValueError("window must be >= 1")
        self.build_id = build_id
        self.secret = secret  # the build secret: signs every sample under its "sample" key
        self.run = run  # the run the samples are made in (named in each, and in the key)
        self.topic = topics(build_id).samples
        self.window = window
        self.max_message_bytes = max_message_bytes
        self.publish_timeout_s = publish_timeout_s
        self.published = 0
        self.republished = 0  # after "no matching subscribers"
        self._lock = threading.Lock()  # one publish/flush at a time; threads may share us
        self._cond = threading.Condition()
        self._done: dict[int, int] = {}  # mid -> PUBACK reason code
        self._in_flight: collections.deque[_Sent] = collections.deque()
        self._conn = MqttConnection(broker_url, client_id, ca_file=ca_file)
        self._conn.client.on_publish = self._conn.guarded(self._handle_puback)

    def __enter__(self) -> SamplePublisher:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:  # already failing: do not wait for PUBACKs on the way out
            self.disconnect()

    def publish(self, sample: Sample) -> None:
        """Encodes and sends one sample; blocks while the in-flight window is full."""
        payload = encode_sample(self.build_id, sample, self.secret, self.run)
        if len(payload) > self.max_message_bytes:
            raise SampleTooLarge(
                f"sample {sample.key} encodes to {len(payload)} bytes, over the "
                f"{self.max_message_bytes}-byte message limit; not published"
            )
        with self._lock:
            while len(self._in_flight) >= self.window:
                self._wait_oldest()
            self._send(payload, sample.key, time.monotonic(), 0)
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

    def disconnect(self) -> None:
        """Closes the connection without waiting for PUBACKs (the build is failing anyway)."""
        self._conn.close()

    def _send(self, payload: bytes, key: str, first_sent: float, attempts: int) -> None:
        # During an outage rc is MQTT_ERR_NO_CONN, yet paho keeps the message and sends it
        # after reconnecting; the window wait covers it.
        info = self._conn.client.publish(self.topic, payload, qos=1)
        if info.rc == mqtt.MQTT_ERR_QUEUE_SIZE:
            raise RuntimeError("paho refused the publish: its outgoing queue is full")
        self._in_flight.append(_Sent(info.mid, payload, key, first_sent, attempts))

    def _wait_oldest(self) -> None:
        sent = self._in_flight[0]
        deadline = time.monotonic() + self.publish_timeout_s
        with self._cond:
            while sent.mid not in self._done:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise PublishTimeout(
                        f"no PUBACK for a sample within {self.publish_timeout_s} s "
                        f"({len(self._in_flight)} in flight)"
                    )
                self._cond.wait(min(left, 1.0))
            reason = self._done.pop(sent.mid)
        self._in_flight.popleft()
        if reason not in (NO_MATCHING_SUBSCRIBERS, QUOTA_EXCEEDED):
            if reason >= 0x80:
                raise PublishRefused(
                    f"the broker refused sample {sent.key} on {self.topic}: "
                    f"{mqtt.ReasonCode(mqtt.PacketTypes.PUBACK, identifier=reason)}"
                )
            return
        if time.monotonic() - sent.first_sent > self.publish_timeout_s:
            raise PublishTimeout(
                f"no writer subscribed to {self.topic} for {self.publish_timeout_s} s; "
                f"sample {sent.key} was not delivered"
            )
        log.info("sample %s not taken (reason 0x%02x); publishing it again", sent.key, reason)
        time.sleep(min(2.0, 0.05 * 2**sent.attempts))
        self.republished += 1
        self._send(sent.payload, sent.key, sent.first_sent, sent.attempts + 1)

    def _handle_puback(self, client, userdata, mid, reason_code, properties) -> None:
        if reason_code.is_failure:
            log.warning("broker refused a sample publish (mid %d): %s", mid, reason_code)
        with self._cond:
            self._done[mid] = reason_code.value
            self._cond.notify_all()
