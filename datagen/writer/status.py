"""A writer's status channel: its own retained status, and every writer's latest one.

A writer publishes its state on ``topics.status(writer_id)`` (QoS 1, retained): ``ready``,
``sealed``, ``prepared``, ``finalized``, ``stopped`` or ``error``, and ``lost`` as its will.
After a reconnect it publishes its last status again: the broker may have published the will
meanwhile, as Mosquitto does for every client when it shuts down. It also keeps the latest status
of every writer of the build (``topics.status_all``), which the finalize round waits on.

Heartbeat: every ``HEARTBEAT_S`` the writer's main loop publishes its current status again with
a ``beat`` counter added (retained, so the broker's copy is always the newest). It comes from
the main loop, not a thread of its own, so a writer whose loop hangs falls silent, and the
coordinator notices (``build.writer_timeout_s``).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import paho.mqtt.client as mqtt

from datagen.transport.connection import MqttConnection
from datagen.transport.envelope import Opener, Sealer
from datagen.transport.topics import Topics
from datagen.writer.finalize import FinalizeError

log = logging.getLogger("datagen.writer")  # the writer process's log
HEARTBEAT_S = 2.0


class WriterStatus:
    """The status channel of writer ``writer_id``; ``conn`` is set once it is connected."""

    def __init__(self, build_topics: Topics, writer_id: str, sealer: Sealer, opener: Opener):
        self.topics = build_topics
        self.writer_id = writer_id
        self.sealer, self.opener = sealer, opener
        self.conn: MqttConnection | None = None  # set once the connection exists
        self.tags: dict[str, Any] = {}  # in every status: the writer's challenge and run
        self._last: dict[str, Any] | None = None
        self._peers: dict[str, dict[str, Any]] = {}
        self._peers_cond = threading.Condition()
        self._beats = 0
        self._next_beat = 0.0

    def will(self) -> tuple[str, bytes, int, bool]:
        """The connection's will: ``lost``, retained."""
        lost = {"state": "lost", "writer": self.writer_id}
        topic = self.topics.status(self.writer_id)
        # its own sequence: the broker publishes it after messages with higher numbers
        return (topic, self.sealer.seal(topic, lost, session=self.sealer.session + "w"), 1, True)

    def publish(self, state: str, **fields: Any) -> None:
        msg = {"state": state, "writer": self.writer_id, **self.tags, **fields}
        self._last = msg
        try:
            if self.conn is None:
                raise RuntimeError("not connected yet")
            topic = self.topics.status(self.writer_id)
            info = self.conn.publish(topic, self.sealer.seal(topic, msg), qos=1, retain=True)
            info.wait_for_publish(10)
        except (RuntimeError, ValueError) as exc:
            log.warning("could not publish status %r: %s", state, exc)

    def reassert(self) -> None:
        """After a reconnect (``on_connected``): publishes the last status again."""
        msg = self._last
        if msg is not None and self.conn is not None:
            topic = self.topics.status(self.writer_id)
            self.conn.publish(topic, self.sealer.seal(topic, msg), qos=1, retain=True)

    def beat_if_due(self) -> None:
        """The heartbeat: called from the writer's loops; publishes at most every HEARTBEAT_S,
        without waiting for the broker (a broker outage must not stall the writer)."""
        now = time.monotonic()
        if self._last is None or self.conn is None or now < self._next_beat:
            return
        self._next_beat = now + HEARTBEAT_S
        self._beats += 1
        topic = self.topics.status(self.writer_id)
        beat = self.sealer.seal(topic, self._last | {"beat": self._beats})
        self.conn.publish(topic, beat, qos=1, retain=True)

    def receive(self, msg: mqtt.MQTTMessage) -> bool:
        """paho's thread: keeps ``msg`` if it is a writer's status; False if it is no status."""
        if not msg.topic.startswith(self.topics.status_prefix):
            return False
        status = self.opener.open(msg.topic, msg.payload) if msg.payload else None
        if status is not None:
            with self._peers_cond:
                self._peers[msg.topic[len(self.topics.status_prefix) :]] = status
                self._peers_cond.notify_all()
        return True

    def wait(
        self, writers: list[str], round_id: str, states: set[str], deadline: float
    ) -> dict[str, dict[str, Any]]:
        """Waits until every writer's latest status of this round is in ``states``; raises
        ``FinalizeError`` when another writer reports an error or at ``deadline``."""

        def reached(w: str) -> bool:
            msg = self._peers.get(w, {})
            return msg.get("round") == round_id and msg.get("state") in states

        with self._peers_cond:
            while True:
                for w in writers:
                    msg = self._peers.get(w, {})
                    if (
                        msg.get("round") == round_id
                        and msg.get("state") == "error"
                        and w != self.writer_id
                    ):
                        raise FinalizeError(f"writer {w!r}: {msg.get('reason')}")
                missing = [w for w in writers if not reached(w)]
                if not missing:
                    return {w: self._peers[w] for w in writers}
                left = deadline - time.monotonic()
                if left <= 0:
                    raise FinalizeError(
                        f"writers {missing} did not reach {'/'.join(sorted(states))} in time; "
                        "is every listed writer running?"
                    )
                self.beat_if_due()
                self._peers_cond.wait(min(left, 1.0))
