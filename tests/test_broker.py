from __future__ import annotations

import os
import pwd
import socket
import subprocess
import threading

import pytest

from datagen.engines.broker import BrokerError, ManagedBroker, parse_broker_url
from datagen.engines.mqtt_client import MqttConnectError, MqttConnection
from datagen.engines.transfer import SamplePublisher, topics
from datagen.engines.wire import decode_sample, encode_sample


def test_parse_broker_url():
    a = parse_broker_url("mqtt://u%40x:p%2Fw%3A@127.0.0.1:1999")
    assert (a.host, a.port, a.username, a.password, a.tls) == (
        "127.0.0.1",
        1999,
        "u@x",
        "p/w:",
        False,
    )
    b = parse_broker_url("mqtts://broker.example")
    assert (b.port, b.username, b.password, b.tls) == (8883, None, None, True)
    assert parse_broker_url("mqtt://h").port == 1883


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("http://h:1", "scheme"),
        ("h:1883", "scheme"),
        ("mqtt://", "no host"),
        ("mqtt://h:port", "bad broker URL"),
        ("mqtt://h:99999", "bad broker URL"),
        ("mqtt://h:1/topic", "path"),
    ],
)
def test_parse_broker_url_rejects(url, reason):
    with pytest.raises(ValueError, match=reason):
        parse_broker_url(url)


def test_broker_requires_its_credentials(broker):
    conn = MqttConnection(broker.url, "test-auth-ok")
    conn.close()
    addr = parse_broker_url(broker.url)
    for url in (
        f"mqtt://{addr.username}:wrong@{addr.host}:{addr.port}",
        f"mqtt://{addr.host}:{addr.port}",
    ):
        with pytest.raises(MqttConnectError, match="refused"):
            MqttConnection(url, "test-auth-bad")


def test_config_raises_limits_and_files_belong_to_the_broker_user(broker):
    conf = (broker.dir / "mosquitto.conf").read_text()
    for line in (
        "allow_anonymous false",
        "persistence true",
        "max_queued_messages 1000000",
        f"max_packet_size {broker.max_message_bytes + 64 * 1024}",
        "max_queued_bytes",
        "max_inflight_messages",
        "autosave_interval",
    ):
        assert line in conf
    if os.geteuid() == 0:
        owner = pwd.getpwuid((broker.dir / "data").stat().st_uid).pw_name
        assert owner == ("mosquitto" if "user mosquitto" in conf else "root")


def test_missing_executable_is_a_clear_error():
    with (
        pytest.raises(BrokerError, match="not found on PATH"),
        ManagedBroker(executable="no-such-mosquitto"),
    ):
        pass


def test_failed_start_reports_the_log_tail():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        b = ManagedBroker(port=port)
        with pytest.raises(BrokerError, match=r"(?s)exited with code.*log tail:.*in use"), b:
            pass
    assert b.dir is None  # temp dir removed


def test_stop_removes_the_temp_dir():
    with ManagedBroker() as b:
        d = b.dir
        assert d.is_dir() and b.running
    assert not d.exists() and not b.running


def test_persistent_session_gets_messages_queued_across_a_broker_restart(make_sample):
    got: list[bytes] = []
    three = threading.Semaphore(0)

    def on_message(msg):
        got.append(msg.payload)
        three.release()

    with ManagedBroker() as b:
        t = topics("restart")
        sub = MqttConnection(
            b.url, "test-persistent", subscriptions=[(t.samples, 1)], session_expiry_s=600
        )
        sub.close()  # away; the broker keeps the session and queues for it
        with SamplePublisher(b.url, "restart", "test-pub") as pub:
            for i in range(3):
                pub.publish(make_sample(i))
        b.stop()  # SIGTERM: mosquitto writes its persistence file
        b.start()
        sub = MqttConnection(
            b.url,
            "test-persistent",
            subscriptions=[(t.samples, 1)],
            session_expiry_s=600,
            on_message=on_message,
        )
        for _ in range(3):
            assert three.acquire(timeout=20)
        sub.close(end_session=True)
    assert sorted(decode_sample(p)[1].index for p in got) == [0, 1, 2]


def test_mosquitto_sub_hex_capture_decodes_per_spec(broker, build_id, make_sample):
    """A retained sample is delivered on subscribe, so no race with mosquitto_sub's start."""
    t = topics(build_id)
    payload = encode_sample(build_id, make_sample(5))
    conn = MqttConnection(broker.url, "test-hex")
    conn.client.publish(t.samples, payload, qos=1, retain=True).wait_for_publish(10)
    a = parse_broker_url(broker.url)
    out = subprocess.run(
        [
            *("mosquitto_sub", "-V", "mqttv5", "-h", a.host, "-p", str(a.port)),
            *("-u", a.username, "-P", a.password, "-t", t.samples, "-C", "1", "-F", "%x"),
        ],
        capture_output=True,
        text=True,
        timeout=20,
        check=True,
    ).stdout
    conn.client.publish(t.samples, b"", qos=1, retain=True).wait_for_publish(10)  # clear it
    conn.close()
    assert bytes.fromhex(out.strip()) == payload
    assert decode_sample(bytes.fromhex(out.strip()))[1].key == "000000005"
