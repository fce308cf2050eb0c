"""The control-plane envelope as a pure function: HKDF against RFC 5869, and which messages open
(genuine, fresh, of this build, topic, role, sender and run). The attacks on a real broker are in
tests/adversarial/test_control_plane.py and test_run_replay.py."""

from __future__ import annotations

import json

from datagen.transport.envelope import Opener, Sealer, hkdf_sha256
from datagen.transport.topics import topics

SECRET = bytes(range(32))


def test_hkdf_matches_rfc_5869_case_1():
    okm = hkdf_sha256(b"\x0b" * 22, bytes(range(13)), bytes(range(0xF0, 0xFA)))
    assert okm.hex() == "3cb25f25faacd57a90434f64d0362f2a2d2d0a90cf1a5a4c5db02d56ecc4c5bf"


def test_only_the_builds_genuine_fresh_messages_open():
    t = topics("build-a")
    writer, coordinator = Sealer(SECRET, t, "writer", "0"), Sealer(SECRET, t, "coordinator", "c")
    opener = Opener(SECRET, t)
    ack = {"key": "000000001", "index": 1, "writer": "0"}
    genuine = writer.seal(t.acks, ack)
    assert opener.open(t.acks, genuine) == ack
    assert opener.open(t.acks, genuine) is None and opener.duplicates == 1  # QoS 1 again
    later = writer.seal(t.acks, ack | {"index": 2, "key": "000000002"})
    assert opener.open(t.acks, later) is not None
    assert opener.open(t.acks, genuine) is None  # an older one replayed
    forged = [
        (t.acks, json.dumps(ack).encode()),  # unsigned
        (t.acks, Sealer(b"\x01" * 32, t, "writer", "0").seal(t.acks, ack)),  # another key
        (t.acks, genuine.replace(b'"index":1', b'"index":7')),  # altered
        (t.control, writer.seal(t.control, {"cmd": "finalize"})),  # a writer may not command
        (t.status("1"), writer.seal(t.status("1"), {"state": "ready", "writer": "1"})),
        (t.acks, Sealer(SECRET, topics("build-b"), "writer", "0").seal(topics("build-b").acks, ack)),
        (t.control, writer.seal(t.acks, {"cmd": "finalize"})),  # moved to another topic
        (t.acks, b"\xff not json"),
    ]  # fmt: skip
    for topic, payload in forged:
        assert opener.open(topic, payload) is None
    assert opener.rejected == {
        "unsigned": 1, "bad_mac": 3, "wrong_role": 1, "wrong_sender": 1, "replayed": 1,
        "wrong_build": 1, "malformed": 1,
    }  # fmt: skip
    assert opener.open(t.control, coordinator.seal(t.control, {"cmd": "announce"})) is not None


def test_a_message_opens_only_in_its_run():
    t, secret = topics("b1"), bytes(range(32))
    run_a, run_b = "a" * 32, "b" * 32
    finalize_of_a = Sealer(secret, t, "coordinator", "coordinator", run_a).seal(
        t.control, {"cmd": "finalize"}
    )
    in_b = Opener(secret, t, run_b)
    assert in_b.open(t.control, finalize_of_a) is None and in_b.rejected == {"wrong_run": 1}
    assert Opener(secret, t, run_a).open(t.control, finalize_of_a) == {"cmd": "finalize"}
    waiting = Sealer(secret, t, "writer", "0").seal(t.status("0"), {"state": "waiting"})
    assert in_b.open(t.status("0"), waiting) is None and in_b.outside_run == 1  # not counted
    assert in_b.open_any_run(t.status("0"), waiting) is None  # the same one again: a duplicate
    version_1 = json.loads(finalize_of_a) | {"v": 1}
    assert in_b.open(t.control, json.dumps(version_1).encode()) is None
    assert in_b.rejected == {"wrong_run": 1, "wrong_version": 1}
