"""The monitor's read-only account (docs/deployment.md, 'The monitor: a read-only account for
browsers'), its ACL lines and commands read from the doc and run as printed, on a real
Mosquitto it reaches over WebSockets: it receives the live status and previews, nothing of the
samples, acks, control or writer status, and whatever it publishes reaches nobody."""

from __future__ import annotations

import secrets
import subprocess
import threading
import time

import paho.mqtt.client as mqtt
import pytest

from adversarial.test_acl import ROLES, Client, T, doc_block, doc_env
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import ManagedBroker

pytestmark = [pytest.mark.adversarial, pytest.mark.mqtt]
MONITOR = "datagen-monitor"


@pytest.fixture
def monitored_broker(tmp_path):
    """Mosquitto with the doc's role ACL plus its monitor lines, and the users its commands
    make (the roles', then the monitor's appended), with a WebSockets listener."""
    passwords = {role: secrets.token_hex(16) for role in (*ROLES, "monitor")}
    for tag in ("acl-users", "acl-monitor-user"):
        made = subprocess.run(["bash", "-euc", doc_block(tag)], cwd=tmp_path,
                              env=doc_env(passwords), capture_output=True, text=True)  # fmt: skip
        assert made.returncode == 0, made.stderr
    users = (tmp_path / "datagen.passwd").read_text()
    assert users.count("$7$") == 4 and f"\n{MONITOR}:$7$" in users
    assert not (tmp_path / "monitor.passwd").exists()
    acl = tmp_path / "datagen.acl"
    acl.write_text(doc_block("acl-roles") + "\n" + doc_block("acl-monitor"))
    users = tmp_path / "datagen.passwd"
    settings = BrokerSettings(acl_file=acl, password_file=users, websockets=True)
    with ManagedBroker(settings) as broker:
        yield broker, passwords


class WebSocketMonitor:
    """The monitor user over MQTT-over-WebSockets, as the page connects (MQTT v5)."""

    def __init__(self, broker: ManagedBroker, password: str):
        self.c = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5, transport="websockets"
        )
        self.c.username_pw_set(MONITOR, password)
        self.received: list[tuple[str, bytes]] = []
        self.pubacks: dict[int, str] = {}
        self.granted: list[str] = []
        self.c.on_message = lambda c, u, m: self.received.append((m.topic, m.payload))
        self.c.on_publish = lambda c, u, mid, rc, p: self.pubacks.__setitem__(mid, str(rc))
        self.c.on_subscribe = lambda c, u, mid, rcs, p: self.granted.extend(map(str, rcs))
        connected = threading.Event()
        self.c.on_connect = lambda c, u, flags, rc, p: connected.set() if not rc.is_failure else None  # fmt: skip
        self.c.connect("127.0.0.1", broker.websockets_port)
        self.c.loop_start()
        assert connected.wait(5), "the monitor was not let in over WebSockets"

    def publish(self, topic: str, payload: bytes) -> str:
        info = self.c.publish(topic, payload, qos=1)
        deadline = time.monotonic() + 5
        while info.mid not in self.pubacks and time.monotonic() < deadline:
            time.sleep(0.01)
        return self.pubacks[info.mid]

    def close(self) -> None:
        self.c.disconnect()
        self.c.loop_stop()


def test_the_monitor_reads_only_the_live_topics_and_publishes_nothing(monitored_broker):
    broker, passwords = monitored_broker
    monitor = WebSocketMonitor(broker, passwords["monitor"])
    writer = Client(broker, passwords, "writer")  # reads samples, control, acks, status
    coordinator = Client(broker, passwords, "coordinator")
    worker = Client(broker, passwords, "worker")
    try:
        # not the writers' shared subscription: see the next test
        everything = [T.samples, T.acks, T.control, T.status_all, T.live, "datagen/#", "#"]
        writer_subscribed = threading.Event()
        writer.c.on_subscribe = lambda c, u, mid, rcs, p: writer_subscribed.set()
        monitor.c.subscribe([(t, 1) for t in everything])
        writer.subscribe(T.shared_samples, T.acks, T.control, T.status_all)
        assert writer_subscribed.wait(5)
        deadline = time.monotonic() + 5
        while len(monitor.granted) < len(everything) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(monitor.granted) == len(everything)  # granted; delivery is what is checked
        sent = {
            (worker, T.samples): b"a sample",
            (writer, T.acks): b"an ack",
            (writer, T.status("A")): b"a writer status",
            (coordinator, T.control): b"a command",
            (coordinator, T.live_status): b'{"state":"running"}',
            (worker, T.live_preview("0")): b"\xff\xd8 a preview",
        }
        for (client, topic), payload in sent.items():
            assert client.publish(topic, payload) == "Success", topic
        # the monitor's own publishes: refused, on every topic, the live ones included
        for topic in (T.samples, T.acks, T.control, T.status("A"), T.live_status, T.live_preview("0")):  # fmt: skip
            assert monitor.publish(topic, f"monitor -> {topic}".encode()) == "Not authorized"
        expected = {b"a sample", b"an ack", b"a writer status", b"a command"}
        deadline = time.monotonic() + 5
        while {p for _, p in writer.received} != expected and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)  # what the monitor should not get has had the time to arrive
        live = {T.live_status, T.live_preview("0")}
        assert set(monitor.received) == {(t, p) for (_, t), p in sent.items() if t in live}
        assert not any(p.startswith(b"monitor ->") for _, p in writer.received)
        assert {p for _, p in writer.received} == expected
    finally:
        for client in (monitor, writer, coordinator, worker):
            client.close()


def test_a_monitor_in_the_writers_share_group_swallows_its_turn_of_the_samples(monitored_broker):
    """What docs/deployment.md warns about: Mosquitto's acl_file checks no SUBSCRIBE, so the
    monitor may join the writers' shared subscription; the broker then gives it its turn of the
    samples and drops them (it may not read them). It reads nothing; the writer misses those
    (a build issues them again after transfer.ack_timeout_s)."""
    broker, passwords = monitored_broker
    monitor = WebSocketMonitor(broker, passwords["monitor"])
    writer, worker = Client(broker, passwords, "writer"), Client(broker, passwords, "worker")
    try:
        subscribed = threading.Event()
        writer.c.on_subscribe = lambda c, u, mid, rcs, p: subscribed.set()
        writer.subscribe(T.shared_samples)
        monitor.c.subscribe(T.shared_samples, qos=1)
        assert subscribed.wait(5)
        deadline = time.monotonic() + 5
        while not monitor.granted and time.monotonic() < deadline:
            time.sleep(0.01)
        assert monitor.granted == ["Granted QoS 1"]
        for i in range(10):
            assert worker.publish(T.samples, b"sample %d" % i) == "Success"
        time.sleep(1.0)
        assert monitor.received == []
        assert 0 < len(writer.received) < 10  # round robin: about half went to the monitor
    finally:
        for client in (monitor, writer, worker):
            client.close()
