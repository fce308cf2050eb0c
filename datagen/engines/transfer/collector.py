"""DataTransfer engine: samples out to the broker, acknowledgements and writer status back.

Topics of one build (all QoS 1; see docs/wire-format.md):

- ``datagen/<build_id>/samples``  wire-format samples, workers -> writers; writers share it
  (``$share/datagen-<build_id>/datagen/<build_id>/samples``): each sample goes to one writer
- ``datagen/<build_id>/acks``     ``{"key", "index", "writer"}`` (or ``{"indices": [...],
  "writer"}``) once samples are durable in the build's directory
- ``datagen/<build_id>/control``  ``finalize`` / ``announce`` commands -> every writer
- ``datagen/<build_id>/status/<writer_id>``  each writer's state, retained: ready / sealed /
  prepared / finalized / error / stopped / lost
"""

from __future__ import annotations

import collections
import json
import logging
import re
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as mqtt

from datagen.engines.transfer.connection import MqttConnection
from datagen.engines.transfer.wire import DEFAULT_MAX_MESSAGE_BYTES, encode_sample
from datagen.sample import KEY_DIGITS, Sample, sample_key

log = logging.getLogger(__name__)

_BUILD_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
WRITER_STATES = ("ready", "sealed", "prepared", "finalized", "error", "stopped", "lost")
DEFAULT_FINALIZE_TIMEOUT_S = 300.0


def valid_build_id(build_id: str) -> bool:
    """Build ids go into topics and client ids: no ``/``, ``+``, ``#`` or spaces."""
    return bool(_BUILD_ID.match(build_id))


@dataclass(frozen=True)
class Topics:
    samples: str
    acks: str
    control: str
    status_prefix: str  # + writer id
    shared_samples: str  # what writers subscribe to

    def status(self, writer_id: str) -> str:
        return self.status_prefix + writer_id

    @property
    def status_all(self) -> str:
        return self.status_prefix + "+"


def topics(build_id: str) -> Topics:
    if not valid_build_id(build_id):
        raise ValueError(f"invalid build id {build_id!r}: use 1-64 of [A-Za-z0-9_.-]")
    base = f"datagen/{build_id}"
    return Topics(
        samples=f"{base}/samples",
        acks=f"{base}/acks",
        control=f"{base}/control",
        status_prefix=f"{base}/status/",
        shared_samples=f"$share/datagen-{build_id}/{base}/samples",
    )


def ack_indices(obj: Any) -> list[int] | None:
    """Sample indices of an ack message (``{"key", "index"}`` or ``{"indices": [...]}``);
    None if malformed (a key not matching its index, a negative or non-integer index)."""
    if not isinstance(obj, dict):
        return None
    if "indices" in obj:
        indices = obj["indices"]
        if not isinstance(indices, list) or not all(_is_index(i) for i in indices):
            return None
        return indices
    index = obj.get("index")
    if not _is_index(index):
        return None
    try:
        return [index] if obj.get("key") == sample_key(index) else None
    except ValueError:
        return None


def _is_index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 10**KEY_DIGITS


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

    A broker PUBACK only means the broker has the sample (pitfall 2); completion is the
    writer's ack, collected by ``AckCollector``. Never re-publish on a connection error:
    paho resends queued messages after reconnecting (pitfall 7). A PUBACK saying "no matching
    subscribers" means the broker dropped the sample because no writer is subscribed (before
    the first writer, after every writer's session ended, or right after a Mosquitto restart,
    which does not restore shared subscriptions until the writers re-subscribe): such a sample
    is published again, backing off up to 2 s, for at most ``publish_timeout_s``; so is one
    refused with "quota exceeded". Any other refusal (e.g. "not authorized" by the broker's
    ACL) raises ``PublishRefused``.
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
    ):
        if window < 1:
            raise ValueError("window must be >= 1")
        self.build_id = build_id
        self.secret = secret  # signs every sample (HMAC-SHA256) when given
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
        payload = encode_sample(self.build_id, sample, self.secret)
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


class AckCollector:
    """Collects writer acks (the set of durable sample indices) and writer status messages.

    Subscribe before any sample is published: acks sent with nobody listening are lost (or
    ask the writers to ``announce`` what they hold). ``on_ack(index)`` and ``on_status(dict)``
    run on paho's network thread; keep them short.
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
        ca_file: str | None = None,
    ):
        self.topics = topics(build_id)
        self._on_ack = on_ack
        self._on_status = on_status
        self._cond = threading.Condition()
        self._acked: set[int] = set()
        self._statuses: list[dict[str, Any]] = []
        self._latest: dict[str, dict[str, Any]] = {}
        # Persistent session: acks sent while we are disconnected (broker restart, coordinator
        # restart with the same client id) wait for us instead of being lost.
        self._conn = MqttConnection(
            broker_url,
            client_id or f"datagen-{build_id}-acks",
            subscriptions=[(self.topics.acks, 1), (self.topics.status_all, 1)],
            on_message=self._handle_message,
            session_expiry_s=session_expiry_s,
            timeout_s=connect_timeout_s,
            ca_file=ca_file,
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
        """Every status message received, oldest first (the first ones may be retained)."""
        with self._cond:
            return list(self._statuses)

    def latest_status(self) -> dict[str, dict[str, Any]]:
        """Each writer's latest status message, by writer id."""
        with self._cond:
            return dict(self._latest)

    def writers_ready(self) -> set[str]:
        """Writers whose latest status is ``ready``."""
        with self._cond:
            return {w for w, msg in self._latest.items() if msg.get("state") == "ready"}

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
        """First status message (number ``after`` onwards) in ``states``, from ``writer`` if
        given; TimeoutError if none."""
        wanted = {states} if isinstance(states, str) else set(states)

        def match(msg: dict[str, Any]) -> bool:
            return msg.get("state") in wanted and (writer is None or msg.get("writer") == writer)

        return self._wait_for(match, after, timeout_s, f"no writer status in {sorted(wanted)}")

    def announce(self, writers: Sequence[str], timeout_s: float | None = 60.0) -> int:
        """Asks the writers to ack again every sample durable in their directory; returns the
        number of acked samples once each listed writer has answered (its acks come first)."""
        with self._cond:
            mark = len(self._statuses)
        token = uuid.uuid4().hex
        self._send({"cmd": "announce", "id": token}, timeout_s)
        for writer in writers:
            self._wait_for(
                lambda m, w=writer: m.get("writer") == w and m.get("announce") == token,
                mark,
                timeout_s,
                f"writer {writer!r} did not answer the announce request",
            )
        return self.count

    def finalize(
        self,
        expected: int,
        manifest: dict[str, Any],
        writers: Sequence[str] | None = None,
        timeout_s: float | None = 60.0,
    ) -> dict[str, Any]:
        """Asks ``writers`` (default: those ready) to finalize; returns the leader's (smallest
        id) ``finalized`` status, or the first ``error`` status of a listed writer. The writers
        give up after ~0.9 ``timeout_s`` (300 s when None) if one of them does not take part."""
        writers = sorted(writers if writers is not None else self.writers_ready())
        if not writers:
            raise ValueError("no writer to finalize: none is ready and none was named")
        leader = writers[0]
        with self._cond:
            mark = len(self._statuses)
        token = uuid.uuid4().hex
        writer_timeout = 0.9 * (timeout_s if timeout_s is not None else DEFAULT_FINALIZE_TIMEOUT_S)
        cmd = {
            "cmd": "finalize",
            "id": token,
            "expected": expected,
            "manifest": manifest,
            "writers": writers,
            "timeout_s": writer_timeout,
        }
        self._send(cmd, timeout_s)

        def final(msg: dict[str, Any]) -> bool:
            if msg.get("round") != token:
                return False
            state, writer = msg.get("state"), msg.get("writer")
            return (writer == leader and state == "finalized") or (
                state == "error" and writer in writers
            )

        return self._wait_for(final, mark, timeout_s, "no final status from the writers")

    def close(self, end_session: bool = True) -> None:
        """``end_session=False`` keeps the broker queueing acks for a later collector."""
        self._conn.close(end_session=end_session)

    def _send(self, cmd: dict[str, Any], timeout_s: float | None) -> None:
        info = self._conn.publish_json(self.topics.control, cmd, qos=1)
        info.wait_for_publish(timeout_s)

    def _wait_for(
        self,
        match: Callable[[dict[str, Any]], bool],
        after: int,
        timeout_s: float | None,
        what: str,
    ) -> dict[str, Any]:
        def find() -> dict[str, Any] | None:
            return next((m for m in self._statuses[after:] if match(m)), None)

        with self._cond:
            if not self._cond.wait_for(lambda: find() is not None, timeout_s):
                raise TimeoutError(
                    f"{what} within {timeout_s} s; statuses seen: {self._statuses[after:]}"
                )
            return find()  # type: ignore[return-value]

    def _handle_message(self, message: mqtt.MQTTMessage) -> None:
        if not message.payload:
            return  # a cleared retained status
        try:
            obj = json.loads(message.payload)
        except ValueError:
            log.warning("ignoring non-JSON message on %s", message.topic)
            return
        if message.topic == self.topics.acks:
            self._handle_ack(obj)
        elif message.topic.startswith(self.topics.status_prefix) and isinstance(obj, dict):
            obj.setdefault("writer", message.topic[len(self.topics.status_prefix) :])
            with self._cond:
                self._statuses.append(obj)
                self._latest[str(obj["writer"])] = obj
                self._cond.notify_all()
            log.info("writer status: %s", obj)
            if self._on_status is not None:
                self._on_status(obj)

    def _handle_ack(self, obj: Any) -> None:
        indices = ack_indices(obj)
        if indices is None:
            log.warning("ignoring malformed ack %.200r", obj)
            return
        with self._cond:
            new = [i for i in indices if i not in self._acked]
            if not new:
                return
            self._acked.update(new)
            self._cond.notify_all()
        if self._on_ack is not None:
            for index in new:
                self._on_ack(index)
