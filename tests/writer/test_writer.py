"""Real Mosquitto, real writer processes, real publishers."""

from __future__ import annotations

import json
import os
import signal
import struct
import threading
import time
import zlib

import pytest

from datagen.dataset.loader import load, verify
from datagen.sample import Sample
from datagen.shards import read_keys
from datagen.transport.collector import AckCollector
from datagen.transport.connection import MqttConnection
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.publisher import SamplePublisher, SampleTooLarge
from datagen.transport.topics import topics
from datagen.transport.wire import encode_sample
from datagen.writer.journal import durable_keys, journal_path

pytestmark = pytest.mark.mqtt

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


# --- several writers sharing one build and one directory ---------------------------------------


def assert_clean_finish(out, n):
    """Exactly ``n`` samples, every checksum verified, no writer bookkeeping left behind."""
    manifest = verify(out)
    assert manifest["samples"] == n
    assert load(out).keys == [f"{i:09d}" for i in range(n)]
    leftovers = [p.name for p in out.iterdir() if p.name.startswith((".writer-", "writer-"))]
    assert leftovers == []
    return manifest


def shard_keys(out, writer_id):
    return {k for p in out.glob(f"shard-{writer_id}-*.tar") for k in read_keys(p)}


def test_two_writers_receive_disjoint_shares_and_one_manifest_covers_all(
    broker, build_id, collector, start_writer, make_sample
):
    a = start_ready(start_writer, collector, writer_id="A", shard_size=8)
    b = start_ready(start_writer, collector, writer_id="B", shard_size=8)
    assert collector.writers_ready() == {"A", "B"}
    samples = [make_sample(i) for i in range(40)]
    publish_all(broker, build_id, samples + samples[:6], "pub-two")  # and 6 duplicates
    assert collector.wait_acked(range(40), timeout_s=TIMEOUT_S), a.log() + b.log()
    held_a, held_b = shard_keys(a.out, "A"), shard_keys(a.out, "B")
    assert held_a and held_b  # both got a share
    status = collector.finalize(40, {"seed": 3}, writers=["A", "B"])
    assert status["state"] == "finalized" and status["writer"] == "A", a.log() + b.log()
    assert status["samples"] == 40
    assert a.wait() == 0 and b.wait() == 0
    manifest = assert_clean_finish(a.out, 40)
    assert manifest["writers"] == ["A", "B"] and manifest["seed"] == 3
    assert {s["name"].split("-")[1] for s in manifest["shards"]} == {"A", "B"}
    # a duplicate copy may have reached both writers; finalize kept one
    assert len(shard_keys(a.out, "A") | shard_keys(a.out, "B")) == 40
    assert not shard_keys(a.out, "A") & shard_keys(a.out, "B")
    assert collector.latest_status()["B"]["state"] == "finalized"


def wait_until(condition, what, timeout_s=TIMEOUT_S):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def test_a_sample_written_by_two_writers_is_kept_once_by_the_smaller_id(
    broker, build_id, collector, start_writer, make_sample
):
    a = start_ready(start_writer, collector, writer_id="A")
    b = start_ready(start_writer, collector, writer_id="B")
    publish_all(broker, build_id, [make_sample(i) for i in range(6)], "pub-pre")
    assert collector.wait_acked(range(6), timeout_s=TIMEOUT_S)
    # B paused: of two consecutive copies of sample 6 the shared subscription gives one to each
    # writer. A writes its copy and acks it; B, resumed, reads its copy before A's ack (the
    # broker sent them in that order) and writes it too.
    os.kill(b.proc.pid, signal.SIGSTOP)
    try:
        publish_all(broker, build_id, [make_sample(6), make_sample(6)], "pub-twice")
        assert collector.wait_acked({6}, timeout_s=TIMEOUT_S)
    finally:
        os.kill(b.proc.pid, signal.SIGCONT)
    wait_until(lambda: "000000006" in durable_keys(a.out, "B"), "B to write its copy")
    assert "000000006" in shard_keys(a.out, "A")
    status = collector.finalize(7, {}, writers=["A", "B"])
    assert status["state"] == "finalized", a.log() + b.log()
    assert a.wait() == 0 and b.wait() == 0
    manifest = assert_clean_finish(a.out, 7)
    assert manifest["duplicate_copies_removed"] == 1
    assert "000000006" in shard_keys(a.out, "A") and "000000006" not in shard_keys(a.out, "B")


def test_a_writer_killed_mid_stream_and_restarted_ends_with_exactly_n(
    broker, build_id, collector, start_writer, make_sample
):
    a = start_ready(start_writer, collector, writer_id="A", shard_size=8)
    b = start_ready(start_writer, collector, writer_id="B", shard_size=8)
    n = 80
    publisher = threading.Thread(
        target=publish_all,
        args=(broker, build_id, [make_sample(i) for i in range(40)], "pub-kill-1"),
    )
    publisher.start()
    assert collector.wait_acked(12, timeout_s=TIMEOUT_S)
    a.stop()  # SIGKILL mid-stream: its open shard is cut back, its share waits in its session
    publisher.join()
    publish_all(broker, build_id, [make_sample(i) for i in range(40, n)], "pub-kill-2")
    a2 = start_ready(start_writer, collector, writer_id="A", shard_size=8)
    assert collector.wait_acked(range(n), timeout_s=TIMEOUT_S), a2.log()
    assert "session present: True" in a2.log()
    status = collector.finalize(n, {}, writers=["A", "B"])
    assert status["state"] == "finalized", a2.log() + b.log()
    assert a2.wait() == 0 and b.wait() == 0
    assert_clean_finish(a2.out, n)
    assert len(shard_keys(a2.out, "A")) >= 20  # its share, including what was held for it


def test_a_stale_session_stops_swallowing_samples_once_it_expires(
    broker, build_id, collector, start_writer, make_sample
):
    dead = start_ready(start_writer, collector, writer_id="A", args=["--session-expiry", "2"])
    b = start_ready(start_writer, collector, writer_id="B")
    dead.stop()  # never comes back; the broker holds its share until the session expires
    publish_all(broker, build_id, [make_sample(i) for i in range(10)], "pub-stale-1")
    client_id = f"datagen-{build_id}-writer-A"
    wait_until(
        lambda: f"Expiring client {client_id} " in broker.log_path.read_text(errors="replace"),
        "the broker to expire the dead writer's session",
    )
    # From now on every sample reaches B ...
    publish_all(broker, build_id, [make_sample(i) for i in range(10, 30)], "pub-stale-2")
    assert collector.wait_acked(range(10, 30), timeout_s=TIMEOUT_S), b.log()
    # ... and what the dead session held (expired with it) is issued again by the coordinator
    missing = sorted(set(range(10)) - collector.acked)
    assert missing  # the dead writer's share, lost with its session
    publish_all(broker, build_id, [make_sample(i) for i in missing], "pub-stale-3")
    assert collector.wait_acked(range(30), timeout_s=TIMEOUT_S), b.log()
    status = collector.finalize(30, {}, writers=["B"])
    assert status["state"] == "finalized", b.log()
    assert b.wait() == 0
    assert verify(b.out)["samples"] == 30


def test_a_second_writer_with_the_same_id_is_refused(collector, start_writer, tmp_path):
    first = start_ready(start_writer, collector, writer_id="A")
    second = start_writer(writer_id="A")
    assert second.wait() == 4
    assert "writer 'A' is already running on" in second.log()
    assert first.proc.poll() is None  # untouched


def test_a_starting_writer_acks_every_sample_already_in_the_directory(
    broker, build_id, collector, start_writer, make_sample
):
    a = start_ready(start_writer, collector, writer_id="A", shard_size=4)
    publish_all(broker, build_id, [make_sample(i) for i in range(10)], "pub-announce")
    assert collector.wait_acked(range(10), timeout_s=TIMEOUT_S)
    a.proc.terminate()  # clean stop: its session ends
    assert a.wait() == 0
    with AckCollector(broker.url, build_id, client_id=f"late-{build_id}") as late:
        mark = len(late.statuses)
        b = start_writer(writer_id="B")  # another writer, same directory
        late.wait_status("ready", writer="B", after=mark, timeout_s=TIMEOUT_S)
        assert late.acked == set(range(10))  # A's samples, announced by B before "ready"
        assert late.wait_status("ready", writer="B", after=mark)["durable"] == 10
    with AckCollector(broker.url, build_id, client_id=f"later-{build_id}") as later:
        assert later.announce(["B"], timeout_s=TIMEOUT_S) == 10
    status = collector.finalize(10, {}, writers=["A", "B"], timeout_s=3)
    assert status["state"] == "error" and "did not reach" in status["reason"]  # A is not running
    assert b.wait() == 3
    assert not (b.out / "manifest.json").exists()
