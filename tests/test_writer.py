"""Real Mosquitto, real writer processes, real publishers."""

from __future__ import annotations

import json
import struct
import threading
import zlib

import pytest

from datagen.engines.broker import ManagedBroker
from datagen.engines.mqtt_client import MqttConnection
from datagen.engines.transfer import AckCollector, SamplePublisher, SampleTooLarge, topics
from datagen.engines.wire import encode_sample
from datagen.loader import load, verify
from datagen.sample import Sample
from datagen.sinks.webdataset import journal_path

TIMEOUT_S = 60


@pytest.fixture
def collector(broker, build_id):
    with AckCollector(broker.url, build_id) as c:
        yield c


def start_ready(start_writer, collector, **kw):
    mark = len(collector.statuses)
    w = start_writer(**kw)
    try:
        collector.wait_status("ready", writer=w.writer_id, after=mark, timeout_s=TIMEOUT_S)
    except TimeoutError:
        pytest.fail(f"writer never became ready; log:\n{w.log()}")
    return w


def publish_all(broker, build_id, samples, client_id):
    with SamplePublisher(broker.url, build_id, client_id, window=4) as pub:
        for s in samples:
            pub.publish(s)


def test_fifty_samples_from_two_publishers(broker, build_id, collector, start_writer, make_sample):
    w = start_ready(start_writer, collector, shard_size=16)
    threads = [
        threading.Thread(
            target=publish_all,
            args=(
                broker,
                build_id,
                [make_sample(i) for i in range(k, 50, 2)],
                f"pub-{build_id}-{k}",
            ),
        )
        for k in range(2)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert collector.wait_acked(range(50), timeout_s=TIMEOUT_S), w.log()
    assert collector.count == 50
    status = collector.finalize(50, {"config": {"scene": "test"}, "seed": 7})
    assert status["state"] == "finalized" and status["samples"] == 50
    assert w.wait() == 0

    manifest = verify(w.out)
    assert manifest["samples"] == 50 and manifest["config"] == {"scene": "test"}
    assert [s["samples"] for s in manifest["shards"]] == [16, 16, 16, 2]
    assert manifest["rejected_messages"] == 0
    assert not journal_path(w.out, "0").exists()
    ds = load(w.out)
    assert ds.keys == [f"{i:09d}" for i in range(50)]
    assert ds[17]["meta"]["index"] == 17


def test_duplicates_are_written_once_and_acked_again(
    broker, build_id, collector, start_writer, make_sample
):
    w = start_ready(start_writer, collector)
    samples = [make_sample(i) for i in range(10)]
    publish_all(broker, build_id, samples + samples[:5], "pub-dup")
    assert collector.wait_acked(range(10), timeout_s=TIMEOUT_S)
    publish_all(broker, build_id, samples[5:], "pub-dup-2")
    status = collector.finalize(10, {})
    assert status["state"] == "finalized", w.log()
    assert w.wait() == 0
    manifest = verify(w.out)
    assert manifest["samples"] == 10
    assert manifest["duplicate_messages"] == 10
    assert len(load(w.out)) == 10


def _framed(header: object, body: bytes) -> bytes:
    h = json.dumps(header).encode()
    msg = struct.pack("<4sHHI", b"DGS1", 1, 0, len(h)) + h + body
    return msg + struct.pack("<I", zlib.crc32(msg))


def test_malformed_messages_are_rejected_and_the_writer_keeps_going(
    broker, build_id, collector, start_writer, make_sample
):
    w = start_ready(start_writer, collector)
    good = encode_sample(build_id, make_sample(1))
    hostile = [
        b"",
        b"\x80\x04\x95pickle-ish",
        b"DGS1" + b"\xff" * 64,
        good[:-1],
        good[:40] + b"X" + good[41:],
        encode_sample("another-build", make_sample(2)),
        encode_sample(build_id, Sample(3, {"json": b"{not json"})),
        _framed(
            {
                "build_id": build_id,
                "index": 4,
                "key": "000000004",
                "parts": [{"name": "a/b", "size": 0}],
            },
            b"",
        ),
        _framed(
            {
                "build_id": build_id,
                "index": 5,
                "key": "000000005",
                "parts": [{"name": "x", "size": 10**9}],
            },
            b"",
        ),
    ]
    raw = MqttConnection(broker.url, f"hostile-{build_id}")
    for payload in hostile:
        raw.client.publish(topics(build_id).samples, payload, qos=1).wait_for_publish(10)
    raw.close()
    publish_all(broker, build_id, [make_sample(1), make_sample(6)], "pub-after-hostile")
    assert collector.wait_acked({1, 6}, timeout_s=TIMEOUT_S)
    status = collector.finalize(2, {})
    assert status["state"] == "finalized", w.log()
    assert w.wait() == 0
    manifest = verify(w.out)
    assert manifest["rejected_messages"] == len(hostile)
    assert load(w.out).keys == ["000000001", "000000006"]
    assert collector.acked == {1, 6}


def test_oversize_sample_is_refused_before_publishing(
    broker, build_id, collector, start_writer, make_sample
):
    w = start_ready(start_writer, collector)
    big = Sample(0, {"json": b"{}", "blob.bin": b"\0" * 20000})
    with SamplePublisher(broker.url, build_id, "pub-size", max_message_bytes=16384) as pub:
        with pytest.raises(
            SampleTooLarge, match=r"000000000 encodes to \d+ bytes, over the 16384-byte"
        ):
            pub.publish(big)
        assert pub.published == 0
        pub.publish(make_sample(1))
    assert collector.wait_acked({1}, timeout_s=TIMEOUT_S)
    # Had the big sample gone out it would have reached the writer first and made it 2.
    status = collector.finalize(1, {})
    assert status["state"] == "finalized" and status["samples"] == 1
    assert w.wait() == 0


def test_finalize_with_the_wrong_count_is_an_error(
    broker, build_id, collector, start_writer, make_sample
):
    w = start_ready(start_writer, collector)
    publish_all(broker, build_id, [make_sample(0)], "pub-count")
    assert collector.wait_acked({0}, timeout_s=TIMEOUT_S)
    status = collector.finalize(2, {})
    assert status["state"] == "error" and "expected 2 samples, have 1" in status["reason"]
    assert w.wait() == 3
    assert not (w.out / "manifest.json").exists()


def test_killed_writer_resumes_without_losing_or_repeating(
    broker, build_id, collector, start_writer, make_sample
):
    w = start_ready(start_writer, collector, shard_size=8)
    publish_all(broker, build_id, [make_sample(i) for i in range(12)], "pub-a")
    assert collector.wait_acked(range(12), timeout_s=TIMEOUT_S)
    w.stop()  # SIGKILL: the second shard is left unterminated
    # Sent while no writer runs: the broker holds them in the writer's persistent session.
    publish_all(broker, build_id, [make_sample(i) for i in range(8, 20)], "pub-b")
    w2 = start_ready(start_writer, collector, shard_size=8)
    assert collector.wait_acked(range(20), timeout_s=TIMEOUT_S), w2.log()
    status = collector.finalize(20, {})
    assert status["state"] == "finalized", w2.log()
    assert w2.wait() == 0
    manifest = verify(w2.out)
    assert manifest["samples"] == 20 and manifest["duplicate_messages"] == 4
    assert load(w2.out).keys == [f"{i:09d}" for i in range(20)]


def test_sigterm_is_a_clean_stop(broker, build_id, collector, start_writer, make_sample):
    w = start_ready(start_writer, collector)
    publish_all(broker, build_id, [make_sample(0)], "pub-term")
    assert collector.wait_acked({0}, timeout_s=TIMEOUT_S)
    mark = len(collector.statuses)
    w.proc.terminate()
    assert w.wait() == 0
    assert collector.wait_status("stopped", after=mark, timeout_s=TIMEOUT_S)["samples"] == 1
    assert (w.out / "shard-0-000000.tar").stat().st_size % 10240 == 0  # terminated tar


def test_broker_restart_mid_build_loses_nothing(build_id, start_writer, make_sample):
    with ManagedBroker() as b, AckCollector(b.url, build_id) as acks:
        w = start_ready(start_writer, acks, broker_url=b.url)
        with SamplePublisher(b.url, build_id, "pub-restart", window=4) as pub:
            for i in range(10):
                pub.publish(make_sample(i))
            pub.flush()
            b.stop()  # SIGTERM: mosquitto saves sessions and queued messages
            b.start()  # same port and credentials; every client reconnects by itself
            for i in range(10, 20):
                pub.publish(make_sample(i))
        assert acks.wait_acked(range(20), timeout_s=TIMEOUT_S), w.log()
        status = acks.finalize(20, {})
        assert status["state"] == "finalized", w.log()
        assert w.wait() == 0
    assert load(w.out).keys == [f"{i:09d}" for i in range(20)]
