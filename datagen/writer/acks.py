"""A writer's acks beyond the one per sample: re-announcing what is durable, and learning what
the other writers acked (``datagen/writer/dataset_writer.py``; message forms: docs/wire-format.md)."""

from __future__ import annotations

import logging
from collections.abc import Set as AbstractSet

import paho.mqtt.client as mqtt

from datagen.sample import sample_key
from datagen.transport.connection import MqttConnection
from datagen.transport.envelope import Opener, Sealer
from datagen.transport.topics import ack_indices

log = logging.getLogger("datagen.writer")  # the writer process's log
ANNOUNCE_BATCH = 10_000  # indices per batched ack: ~80 KB, far below any broker's packet limit


def announce(
    conn: MqttConnection, sealer: Sealer, acks_topic: str, writer_id: str, keys: AbstractSet[str]
) -> None:
    """Acks every key in ``keys`` again, in batches (``{"indices": [...]}``)."""
    indices = sorted(int(k) for k in keys)
    for start in range(0, len(indices), ANNOUNCE_BATCH):
        ack = {"indices": indices[start : start + ANNOUNCE_BATCH], "writer": writer_id}
        conn.publish(acks_topic, sealer.seal(acks_topic, ack))
    if indices:
        log.info("announced %d durable samples", len(indices))


def others_acked_keys(opener: Opener, msg: mqtt.MQTTMessage, writer_id: str) -> set[str]:
    """The keys another writer's genuine ack says are durable (none for our own, or a forgery)."""
    obj = opener.open(msg.topic, msg.payload)
    indices = ack_indices(obj) if obj is not None else None
    if obj is None or indices is None or obj.get("writer") == writer_id:
        return set()
    return {sample_key(i) for i in indices}
