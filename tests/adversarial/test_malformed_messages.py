"""Malformed messages from any broker user (issue 22, high 4 and two medium findings): a
non-ASCII MAC, a lone surrogate, 100k-deep JSON, oversized JSON and binary garbage on a build's
``control``, ``acks`` and ``status`` topics, live and retained before the build starts, are
dropped and counted; the coordinator's MQTT thread and the writers keep going and the build ends
with exactly N verified samples. A 50k-deep wire header is a ``WireError``; a deep journal line
stops the writer with one line naming the journal file and the line.
"""

from __future__ import annotations

import json
import secrets
import struct
import time
import zlib
from collections.abc import Iterator
from pathlib import Path

import paho.mqtt.client as mqtt
import pytest

from datagen.config import config_from_dict
from datagen.dataset.loader import check_complete, verify
from datagen.pipeline.run import run_build
from datagen.sample import Sample
from datagen.transport import envelope, wire
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.collector import AckCollector
from datagen.transport.connection import MqttConnection
from datagen.transport.publisher import SamplePublisher
from datagen.transport.topics import topics
from datagen.transport.wire import SECRET_ENV, WireError, decode_sample, encode_sample
from datagen.writer.journal import journal_path, recover
from datagen.writer.journal_lines import JournalError
from datagen.writer.shard_writer import ShardWriter

pytestmark = [pytest.mark.adversarial]
TIMEOUT_S = 30

# the envelope's version and run as a genuine message has them, so each reaches the MAC check
_V = f'"v": {envelope.VERSION}, "run": ""'
POISON = {
    "non-ASCII mac": f'{{{_V}, "mac": "é"}}'.encode(),
    "lone surrogate": f'{{{_V}, "mac": "00", "body": {{"state": "\\ud800"}}}}'.encode(),
    "100k-deep JSON": b"[" * 100_000 + b"]" * 100_000,
    "oversized JSON": b'{"pad": "' + b"x" * (2 * 2**20) + b'"}',
    "binary garbage": b"\x80\x04\x95\xff\x00\xfe not JSON",
}


class Hostile:
    """A client with the broker's credentials and nothing else (no build secret); what it left
    retained is cleared when it closes."""

    def __init__(self, url: str):
        address = parse_broker_url(url)
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5)
        self.client.username_pw_set(address.username, address.password)
        self.client.connect(address.host, address.port)
        self.client.loop_start()
        self.retained: set[str] = set()

    def send(self, topic: str, payload: bytes, retain: bool = False) -> None:
        self.client.publish(topic, payload, qos=1, retain=retain).wait_for_publish(10)
        if retain:
            self.retained.add(topic)

    def close(self) -> None:
        for topic in self.retained:  # leave the session broker as it was
            self.client.publish(topic, b"", qos=1, retain=True).wait_for_publish(10)
        self.client.loop_stop()
        self.client.disconnect()


@pytest.fixture
def hostile(broker) -> Iterator[Hostile]:
    h = Hostile(broker.url)
    yield h
    h.close()


def _retain_poison(hostile: Hostile, build_id: str) -> None:
    """What breaks every later build with this id: poison retained on its topics."""
    t = topics(build_id)
    hostile.send(t.control, POISON["100k-deep JSON"], retain=True)
    hostile.send(t.acks, POISON["non-ASCII mac"], retain=True)
    for i, payload in enumerate(POISON.values()):
        hostile.send(t.status(f"evil{i}"), payload, retain=True)


@pytest.mark.mqtt
def test_poison_on_every_control_topic_is_dropped_and_counted(
    broker, build_id, start_writer, hostile, make_sample, monkeypatch
):
    secret = secrets.token_bytes(32)
    monkeypatch.setenv(SECRET_ENV, secret.hex())
    t = topics(build_id)
    _retain_poison(hostile, build_id)
    with AckCollector(broker.url, build_id, secret=secret) as collector:
        writer = start_writer(shard_size=3)
        try:
            collector.wait_status("ready", writer="0", timeout_s=TIMEOUT_S)
        except TimeoutError:
            pytest.fail(f"the collector heard no 'ready'; writer log:\n{writer.log()[-3000:]}")
        for payload in POISON.values():
            for topic in (t.control, t.acks, t.status("evil")):
                hostile.send(topic, payload)
        with SamplePublisher(
            broker.url, build_id, "pub-" + build_id, secret=secret, run=collector.run
        ) as pub:
            for i in range(4):
                pub.publish(make_sample(i))
        assert collector.wait_acked(range(4), timeout_s=TIMEOUT_S), writer.log()[-3000:]
        status = collector.finalize(4, {}, timeout_s=TIMEOUT_S)
        rejected = collector.rejected
    assert status["state"] == "finalized", writer.log()[-3000:]
    assert writer.wait() == 0
    assert "Traceback" not in writer.log()
    manifest = verify(writer.out)
    assert manifest["samples"] == 4
    # the writer: each poison on control, acks and status, and the retained ones
    assert manifest["rejected_control_messages"] >= 3 * len(POISON) + 2
    # the coordinator's side: each poison on acks and status, and the retained ones
    assert rejected.get("malformed", 0) >= len(POISON), rejected
    assert sum(rejected.values()) >= 2 * len(POISON) + 1 + len(POISON), rejected
    assert "callback_error" not in rejected


@pytest.mark.mqtt
@pytest.mark.sim
@pytest.mark.slow
def test_a_build_whose_topics_hold_retained_poison_finishes(broker, build_id, hostile, tmp_path):
    _retain_poison(hostile, build_id)
    config = config_from_dict({
        "num_samples": 2, "seed": 3, "render": {"width": 64, "height": 48, "wrist_camera": False},
        "objects": {"count": [1, 1]}, "physics": {"settle_time": 0.1},
    })  # fmt: skip
    result = run_build(config, tmp_path / "ds", 1, broker_url=broker.url, build_id=build_id)
    assert result.samples == 2 and result.restarts["writer"] == 0
    manifest = check_complete(tmp_path / "ds", 2, build_id)
    assert manifest["rejected_control_messages"] >= 1  # the retained control poison
    coordinator = manifest["rejected_control_messages_coordinator"]
    assert coordinator.get("malformed", 0) >= 1 and "callback_error" not in coordinator


@pytest.mark.mqtt
def test_a_callback_that_raises_is_counted_and_the_client_goes_on(broker, build_id, hostile):
    topic, got = f"datagen/{build_id}/test", []

    def handler(msg: mqtt.MQTTMessage) -> None:  # a handler with a bug
        got.append(msg.payload)
        if msg.payload == b"boom":
            raise RuntimeError("a bug in a handler")

    conn = MqttConnection(
        broker.url, f"cb-{build_id}", subscriptions=[(topic, 1)], on_message=handler
    )
    try:
        hostile.send(topic, b"boom")
        hostile.send(topic, b"after")
        deadline = time.monotonic() + 10
        while b"after" not in got and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        conn.close()
    assert got == [b"boom", b"after"] and conn.callback_errors == 1


def _framed(header: bytes, body: bytes = b"") -> bytes:
    """An unsigned message with a valid CRC around ``header`` (any bytes)."""
    msg = struct.pack("<4sHHI", b"DGS1", wire.VERSION, 0, len(header)) + header + body
    return msg + struct.pack("<I", zlib.crc32(msg))


def test_a_50k_deep_wire_header_is_a_wire_error():
    with pytest.raises(WireError, match=r"header.*deeper than 64"):
        decode_sample(_framed(b"[" * 50_000 + b"]" * 50_000))


@pytest.mark.mqtt
def test_deep_headers_and_json_parts_do_not_stop_a_writer_without_the_secret(
    broker, build_id, start_writer, hostile, make_sample, monkeypatch
):
    monkeypatch.delenv(SECRET_ENV, raising=False)  # a writer that checks no signature
    with AckCollector(broker.url, build_id) as collector:
        writer = start_writer(shard_size=3)
        collector.wait_status("ready", writer="0", timeout_s=TIMEOUT_S)
        deep = b"[" * 50_000 + b"]" * 50_000
        crafted = [
            _framed(deep),
            encode_sample(build_id, Sample(7, {"json": deep})),
            encode_sample(build_id, Sample(8, {"json": b'{"x": "\\udfff"}'})),
        ]
        for payload in crafted:
            hostile.send(topics(build_id).samples, payload)
        with SamplePublisher(broker.url, build_id, "pub-" + build_id) as pub:
            for i in range(3):
                pub.publish(make_sample(i))
        assert collector.wait_acked(range(3), timeout_s=TIMEOUT_S), writer.log()[-3000:]
        status = collector.finalize(3, {}, timeout_s=TIMEOUT_S)
    assert status["state"] == "finalized", writer.log()[-3000:]
    assert writer.wait() == 0 and "Traceback" not in writer.log()
    assert verify(writer.out)["rejected_messages"] == len(crafted)


def _deep_journal(out: Path, make_sample) -> tuple[Path, bytes]:
    """A writer's directory after a crash: an open shard with two durable batches, and a
    100k-deep line between their journal entries. Returns the shard and its bytes."""
    sink = ShardWriter(out, "0", 10)
    for i in range(4):
        sink.write(make_sample(i))
        if i in (1, 3):
            sink.flush_durable()
    shard = next(out.glob("shard-*.tar"))
    lines = journal_path(out, "0").read_text().splitlines(keepends=True)
    lines.insert(1, "[" * 100_000 + "]" * 100_000 + "\n")
    journal_path(out, "0").write_text("".join(lines))
    return shard, shard.read_bytes()  # the writer "crashed": the sink is never closed


@pytest.mark.mqtt
def test_a_deep_journal_line_stops_the_writer_naming_the_file_and_line(
    start_writer, make_sample, tmp_path
):
    out = tmp_path / "ds"
    shard, before = _deep_journal(out, make_sample)
    writer = start_writer(out=out)
    assert writer.wait(TIMEOUT_S) == 1
    log = writer.log()
    assert f"{journal_path(out, '0')} line 2" in log and "deeper than 64" in log, log
    assert "Traceback" not in log
    assert shard.read_bytes() == before  # nothing cut back on a journal it could not read


def test_a_journal_offset_past_the_shards_end_is_refused_not_cut_back_to(tmp_path, make_sample):
    out = tmp_path / "ds"
    sink = ShardWriter(out, "0", 10)
    for i in range(2):
        sink.write(make_sample(i))
        sink.flush_durable()
    entry = json.loads(journal_path(out, "0").read_text().splitlines()[-1])
    with open(journal_path(out, "0"), "a") as f:
        f.write(json.dumps(entry | {"offset": 2**30}) + "\n")  # "durable up to 1 GiB"
    shard = out / entry["shard"]
    before = shard.read_bytes()
    with pytest.raises(JournalError, match=f"{entry['shard']} durable up to byte {2**30}, but"):
        recover(out, "0")
    assert shard.read_bytes() == before


def test_a_torn_last_journal_line_is_skipped(tmp_path, make_sample):
    out = tmp_path / "ds"
    sink = ShardWriter(out, "0", 10)
    for i in range(3):
        sink.write(make_sample(i))
        sink.flush_durable()
    with open(journal_path(out, "0"), "a") as f:
        f.write(json.dumps({"shard": "x", "offset": 1})[:9])  # the crash cut this append
    recovered = recover(out, "0")
    assert sorted(recovered.keys) == [f"{i:09d}" for i in range(3)]
