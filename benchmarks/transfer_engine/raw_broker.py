"""The broker's raw rate: bare paho clients publishing payloads of the engine's sizes at QoS 1,
``WINDOW`` in flight each, to as many shared-subscription readers, through a Mosquitto this
starts. Each side runs in its own spawned process."""

from __future__ import annotations

import multiprocessing as mp
import os
import secrets
import time

import paho.mqtt.client as mqtt

from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.connection import MqttConnection
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.topics import topics

from .process_watch import CpuWatch

MAX_MESSAGE = 64 * 2**20
# In-flight samples per producer, as a worker's transfer.window: 64 of 1.5 MiB samples from
# each producer buried the broker (no answer to the coordinator's probe for 60 s, re-issues).
WINDOW = 8


def _subscriber(url, topic, conn) -> None:
    """Counts what it receives; sends (first, last, count) every 0.2 s until told to stop."""
    state = {"count": 0, "first": 0.0, "last": 0.0}

    def on_message(message):
        now = time.monotonic()
        state["first"] = state["first"] or now
        state["last"], state["count"] = now, state["count"] + 1

    name = f"raw-sub-{secrets.token_hex(4)}"
    mqtt_conn = MqttConnection(url, name, subscriptions=[(topic, 1)], on_message=on_message)
    try:
        conn.send("ready")
        while not conn.poll(0.2):
            conn.send((state["first"], state["last"], state["count"]))
    finally:
        mqtt_conn.close()


def _publisher(url, topic, sizes, count, conn) -> None:
    """A bare paho client: ``count`` QoS 1 publishes, ``WINDOW`` in flight (a host's)."""
    payloads = [os.urandom(size) for size in sizes]
    address = parse_broker_url(url)
    client = mqtt.Client(
        mqtt.CallbackAPIVersion.VERSION2,
        client_id=f"raw-pub-{secrets.token_hex(4)}",
        protocol=mqtt.MQTTv5,
    )
    client.username_pw_set(address.username, address.password)
    client.max_inflight_messages_set(WINDOW)
    client.max_queued_messages_set(0)
    client.connect(address.host, address.port)
    client.loop_start()
    try:
        conn.recv()  # go
        infos = [client.publish(topic, payloads[i % len(payloads)], qos=1) for i in range(count)]
        for info in infos:
            info.wait_for_publish(600)
        conn.send("sent")
    finally:
        client.disconnect()
        client.loop_stop()


def _start(context, target, *args):
    ours, theirs = context.Pipe()
    process = context.Process(target=target, args=(*args, theirs))
    process.start()
    return process, ours


def raw(sizes: list[int], n: int, publishers: int, readers: int) -> dict:
    """The broker's rate for ``n`` payloads of ``sizes`` from ``publishers`` bare QoS 1
    clients to ``readers`` shared-subscription readers."""
    context = mp.get_context("spawn")
    with ManagedBroker(BrokerSettings(max_message_bytes=MAX_MESSAGE)) as broker:
        cpu = CpuWatch()
        cpu.watch(broker.pid, "broker")
        names = topics(secrets.token_hex(6))
        subs = [
            _start(context, _subscriber, broker.url, names.shared_samples) for _ in range(readers)
        ]
        for _, conn in subs:
            conn.recv()  # subscribed
        pubs = []
        for k in range(publishers):
            count = n // publishers + (k < n % publishers)
            pubs.append(_start(context, _publisher, broker.url, names.samples, sizes, count))
        time.sleep(1.0)  # connected
        for _, conn in pubs:
            conn.send("go")
        latest = [(0.0, 0.0, 0)] * readers
        deadline = time.monotonic() + 600
        while sum(s[2] for s in latest) < n and time.monotonic() < deadline:
            for k, (_, conn) in enumerate(subs):
                while conn.poll(0.05):
                    latest[k] = conn.recv()
        for _, conn in subs:
            conn.send("stop")
        for _, conn in pubs:
            conn.recv()  # every publish acknowledged
        for process, _ in [*subs, *pubs]:
            process.join(timeout=30)
        roles = cpu.by_role()
    got = sum(s[2] for s in latest)
    first = min(s[0] for s in latest if s[2])
    last = max(s[1] for s in latest)
    return {
        "samples_per_s": round((got - 1) / (last - first), 1),
        "received": got,
        "cpu_ms_per_sample": {r: round(1000 * s / n, 3) for r, s in roles.items()},
    }
