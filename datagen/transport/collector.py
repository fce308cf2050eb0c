"""Acknowledgements and writer status back: ``AckCollector`` (``datagen/<build_id>/acks`` and
``datagen/<build_id>/status/+``), and the ``bind`` / ``finalize`` / ``announce`` commands it
sends on ``datagen/<build_id>/control``. Topics and the ack schema: ``topics``; runs and
binding: ``run_binding``.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as mqtt

from datagen.index_set import IndexSet
from datagen.transport import run_binding
from datagen.transport.connection import MqttConnection
from datagen.transport.envelope import Opener, Sealer
from datagen.transport.run_binding import RunBinding
from datagen.transport.topics import DEFAULT_FINALIZE_TIMEOUT_S, ack_indices, topics

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FinalizeRound:
    token: str
    writers: list[str]  # sorted: the first is the leader
    mark: int  # statuses before the command: the answers come after
    cmd: dict[str, Any]


class AckCollector:
    """Collects writer acks (the set of durable sample indices) and writer status messages.

    Subscribe before any sample is published: acks sent with nobody listening are lost (or
    ask the writers to ``announce`` what they hold). ``on_ack(index)`` and ``on_status(dict)``
    run on paho's network thread; keep them short.

    With the build secret it speaks for one run (``run``; a fresh one if not given): it takes
    only that run's acks and statuses, and binds to it every writer it hears waiting for a run
    (or bound to another one) with a ``bind`` command that echoes the writer's challenge.
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
        secret: bytes | None = None,
        run: RunBinding | None = None,
    ):
        self.topics = topics(build_id)
        self.run = run if run is not None or not secret else RunBinding.draw({}, 0)
        run_id = self.run.run if self.run is not None else ""
        # with the build secret: commands signed, acks and status accepted only when signed
        self._sealer = Sealer(secret, self.topics, "coordinator", "coordinator", run_id)
        self._opener = Opener(secret, self.topics, run_id)
        self._conn: MqttConnection | None = None  # binds asked for before it exists wait
        self._unsent_binds: list[dict[str, Any]] = []
        self._on_ack = on_ack
        self._on_status = on_status
        self._cond = threading.Condition()
        self._acked = IndexSet()  # about a bit per durable sample: flat over long builds
        self._statuses: list[dict[str, Any]] = []
        self._latest: dict[str, dict[str, Any]] = {}
        self._heard: dict[str, float] = {}  # writer -> monotonic time of its last message
        # Persistent session: acks sent while we are disconnected (a broker restart) wait for
        # us instead of being lost. Its client id is new for every collector (unguessable).
        conn = MqttConnection(
            broker_url,
            client_id or run_binding.client_id(build_id, "acks"),
            subscriptions=[(self.topics.acks, 1), (self.topics.status_all, 1)],
            on_message=self._handle_message,
            session_expiry_s=session_expiry_s,
            timeout_s=connect_timeout_s,
            ca_file=ca_file,
        )
        with self._cond:
            self._conn, unsent, self._unsent_binds = conn, self._unsent_binds, []
        for cmd in unsent:
            self._publish_bind(cmd)

    def __enter__(self) -> AckCollector:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def acked(self) -> IndexSet:
        """A copy of the durable indices (about a bit each)."""
        with self._cond:
            return self._acked.copy()

    @property
    def rejected(self) -> dict[str, int]:
        """Control-plane messages dropped, by reason (unsigned, malformed, bad_mac, replayed,
        ...; ``callback_error``: handling one raised, which ``MqttConnection.guarded`` caught)."""
        errors = self._conn.callback_errors if self._conn is not None else 0
        return dict(self._opener.rejected) | ({"callback_error": errors} if errors else {})

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

    def last_heard(self, writer: str) -> float | None:
        """``time.monotonic()`` when writer ``writer``'s last genuine status or ack arrived
        (writers repeat their status every 2 s as a heartbeat); None if never."""
        with self._cond:
            return self._heard.get(writer)

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
        round_ = self.send_finalize(expected, manifest, writers, timeout_s)
        return self.wait_finalized(round_, timeout_s)

    def send_finalize(
        self,
        expected: int,
        manifest: dict[str, Any],
        writers: Sequence[str] | None = None,
        timeout_s: float | None = 60.0,
    ) -> FinalizeRound:
        """The first half of :meth:`finalize`: sends the command, returns the round to wait on
        (:meth:`wait_finalized`) or to send again after a broker restart (:meth:`resend`)."""
        writers = sorted(writers if writers is not None else self.writers_ready())
        if not writers:
            raise ValueError("no writer to finalize: none is ready and none was named")
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
        round_ = FinalizeRound(token, writers, mark, cmd)
        # a broker that hangs now must not block us: the command stays queued in paho
        self.resend(round_, 10.0 if timeout_s is None else min(timeout_s, 10.0))
        return round_

    def resend(self, round_: FinalizeRound, timeout_s: float | None = 10.0) -> None:
        """Sends the round's command (again, after a broker restart may have lost it)."""
        self._send(round_.cmd, timeout_s)

    def wait_finalized(self, round_: FinalizeRound, timeout_s: float | None) -> dict[str, Any]:
        """The leader's ``finalized`` status of the round, or a listed writer's ``error``;
        TimeoutError if neither comes within ``timeout_s``."""
        leader = round_.writers[0]

        def final(msg: dict[str, Any]) -> bool:
            if msg.get("round") != round_.token:
                return False
            state, writer = msg.get("state"), msg.get("writer")
            return (writer == leader and state == "finalized") or (
                state == "error" and writer in round_.writers
            )

        return self._wait_for(final, round_.mark, timeout_s, "no final status from the writers")

    def close(self, end_session: bool = True) -> None:
        """``end_session=False`` keeps the broker queueing acks for a later collector."""
        self._conn.close(end_session=end_session)

    def _send(self, cmd: dict[str, Any], timeout_s: float | None) -> None:
        payload = self._sealer.seal(self.topics.control, cmd)
        info = self._conn.publish(self.topics.control, payload, qos=1)
        if info.rc == mqtt.MQTT_ERR_NO_CONN:
            return  # queued: paho sends it once reconnected (docs/mqtt-pitfalls.md, pitfall 7)
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
        if message.topic.startswith(self.topics.status_prefix):
            opened = self._opener.open_any_run(message.topic, message.payload)
            run, obj = opened if opened is not None else ("", None)
            if obj is not None and run != self._opener.run:
                self._bind(message.topic[len(self.topics.status_prefix) :], obj)
                return  # a writer not (yet) in our run: only its challenge matters
        else:
            obj = self._opener.open(message.topic, message.payload)
        if obj is None:
            log.debug("dropped a message on %s: %s", message.topic, dict(self._opener.rejected))
            return
        if message.topic == self.topics.acks:
            self._handle_ack(obj)
        elif message.topic.startswith(self.topics.status_prefix) and isinstance(obj, dict):
            obj.setdefault("writer", message.topic[len(self.topics.status_prefix) :])
            writer = str(obj["writer"])
            with self._cond:
                self._heard[writer] = time.monotonic()
                if _is_repeat(obj, self._latest.get(writer)):
                    self._latest[writer] = obj
                    return  # a heartbeat: nothing new to wait on
                self._statuses.append(obj)
                self._latest[writer] = obj
                self._cond.notify_all()
            log.info("writer status: %s", obj)
            if self._on_status is not None:
                self._on_status(obj)

    def _bind(self, writer: str, status: dict[str, Any]) -> None:
        """Binds ``writer`` to our run if ``status`` (of another run, or of none) says it waits
        for one or serves another: a ``bind`` echoing the challenge in it. The writer refuses
        a bind with any other challenge, so a recording of another run cannot bind it."""
        challenge = status.get("challenge")
        if self.run is None or not isinstance(challenge, str):
            return
        if status.get("state") not in ("waiting", "ready"):
            return
        cmd = {"cmd": "bind", "writer": writer, "challenge": challenge, **self.run.fields()}
        with self._cond:
            if self._conn is None:
                self._unsent_binds.append(cmd)
                return
        self._publish_bind(cmd)

    def _publish_bind(self, cmd: dict[str, Any]) -> None:
        log.info("binding writer %r to run %s", cmd["writer"], cmd["run"])
        self._conn.publish(self.topics.control, self._sealer.seal(self.topics.control, cmd), qos=1)

    def _handle_ack(self, obj: Any) -> None:
        indices = ack_indices(obj)
        if indices is None:
            log.warning("ignoring malformed ack %.200r", obj)
            return
        with self._cond:
            self._heard[str(obj.get("writer"))] = time.monotonic()
            new = [i for i in indices if i not in self._acked]
            if not new:
                return
            self._acked.update(new)
            self._cond.notify_all()
        if self._on_ack is not None:
            for index in new:
                self._on_ack(index)


def _is_repeat(status: dict[str, Any], previous: dict[str, Any] | None) -> bool:
    """A heartbeat repeats the writer's current status with a ``beat`` counter added."""
    if "beat" not in status or previous is None:
        return False
    return {k: v for k, v in status.items() if k != "beat"} == {
        k: v for k, v in previous.items() if k != "beat"
    }
