"""Fuzz: every decoder of what arrives from the network or from a writer's journal, over
arbitrary bytes and over mutations of genuine messages (issue 22). Envelopes (``Opener``),
writer status (``WriterStatus.receive``, ``AckCollector`` through paho's own callback), wire
samples (``decode_sample``) and journals (``recover``, ``durable_keys``): no exception escapes
but the documented one (``WireError`` for a sample; for one's own journal ``JournalError``,
naming the file and the line or the shard), every dropped message is counted once, and
recovery writes nothing outside the output folder.
"""

from __future__ import annotations

import json
import shutil
import struct
import tempfile
import zlib
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from datagen.sample import Sample
from datagen.transport.collector import AckCollector
from datagen.transport.envelope import Opener, Sealer
from datagen.transport.run_binding import RunBinding
from datagen.transport.topics import topics
from datagen.transport.wire import VERSION, WireError, decode_sample, encode_sample
from datagen.writer.journal import durable_keys, journal_path, recover
from datagen.writer.journal_lines import JournalError
from datagen.writer.shard_writer import ShardWriter
from datagen.writer.status import WriterStatus

pytestmark = [pytest.mark.adversarial]

FUZZ = settings(
    max_examples=300,
    deadline=None,
    database=None,  # writes nothing into the repository (.hypothesis/)
    suppress_health_check=[HealthCheck.too_slow],
)
SECRET = bytes(range(32))
BUILD = "fuzz-build"
T = topics(BUILD)
RUN = RunBinding.draw({"scene": "fuzz"}, 7)
TOPICS = [T.acks, T.control, T.status("w1"), T.status("w2"), topics("other").acks, "x/y"]

# JSON text that a value could be replaced with: out of every bound safe_json sets, or just odd
NASTY_JSON = st.one_of(
    st.builds(json.dumps, st.one_of(st.integers(), st.floats(), st.text(max_size=8))),
    st.sampled_from(
        [
            *('"\\ud800"', '"\\udfff x"', '"é"', "NaN", "-Infinity", "1e999", "null", "true"),
            *("[]", "{}", '{"": []}', "1" * 5000, '"' + "x" * 5000 + '"', "-0", "0.0"),
        ]
    ),
    st.integers(1, 3000).map(lambda n: "[" * n + "]" * n),
    st.integers(1, 3000).map(lambda n: '{"a":' * n + "1" + "}" * n),
)


def _paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path into the nested objects of ``value``."""
    found = []
    if isinstance(value, dict):
        for key, item in value.items():
            found.append((*prefix, key))
            found.extend(_paths(item, (*prefix, key)))
    return found


def mutated_json(data: st.DataObject, doc: dict[str, Any]) -> bytes:
    """``doc`` as JSON with one value replaced by ``NASTY_JSON`` text, or a key dropped."""
    doc = json.loads(json.dumps(doc))
    path = data.draw(st.sampled_from(_paths(doc)))
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    if data.draw(st.booleans()):
        del parent[path[-1]]
        return json.dumps(doc).encode()
    parent[path[-1]] = "\x00nasty\x00"
    return json.dumps(doc).replace('"\\u0000nasty\\u0000"', data.draw(NASTY_JSON)).encode()


def mutated_bytes(data: st.DataObject, payload: bytes) -> bytes:
    """``payload`` cut short, or with bytes flipped, inserted or deleted."""
    raw = bytearray(payload)
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, max(0, len(raw) - 1)))
        how = data.draw(st.sampled_from(["flip", "insert", "delete", "cut"]))
        if how == "flip" and raw:
            raw[at] ^= 1 << data.draw(st.integers(0, 7))
        elif how == "insert":
            raw[at:at] = data.draw(st.binary(min_size=1, max_size=8))
        elif how == "delete":
            del raw[at : at + data.draw(st.integers(1, 8))]
        else:
            del raw[at:]
    return bytes(raw)


def hostile_payload(data: st.DataObject, genuine: bytes) -> bytes:
    kind = data.draw(st.sampled_from(["bytes", "json", "mutated"]))
    if kind == "bytes":
        return data.draw(st.binary(max_size=300))
    if kind == "json":
        return mutated_json(data, json.loads(genuine))
    return mutated_bytes(data, genuine)


def genuine_message(data: st.DataObject, opener_run: str) -> tuple[str, bytes]:
    """A message a writer or the coordinator of this build really sends, in our run or in none."""
    topic = data.draw(st.sampled_from([T.acks, T.control, T.status("w1")]))
    role, sender = ("coordinator", "coordinator") if topic == T.control else ("writer", "w1")
    body: dict[str, Any] = {
        T.acks: {"key": "000000003", "index": 3, "writer": "w1"},
        T.control: {"cmd": "finalize", "id": "r", "expected": 3, "manifest": {"a": [1]}},
        T.status("w1"): {"state": "ready", "writer": "w1", "samples": 1},
    }[topic]
    run = data.draw(st.sampled_from([opener_run, ""]))
    return topic, Sealer(SECRET, T, role, sender, run).seal(topic, body)


def hostile_message(data: st.DataObject) -> mqtt.MQTTMessage:
    genuine_topic, genuine = genuine_message(data, RUN.run)
    topic = data.draw(st.one_of(st.just(genuine_topic), st.sampled_from(TOPICS)))
    msg = mqtt.MQTTMessage(topic=topic.encode())
    msg.payload = hostile_payload(data, genuine)
    return msg


def _counted(opener: Opener) -> int:
    return sum(opener.rejected.values()) + opener.duplicates + opener.outside_run


@FUZZ
@given(st.data(), st.booleans())
def test_envelopes_never_raise_and_every_drop_is_counted(data, with_secret):
    opener = Opener(SECRET if with_secret else None, T, RUN.run)
    genuine_topic, genuine = genuine_message(data, RUN.run)
    topic = data.draw(st.one_of(st.just(genuine_topic), st.sampled_from(TOPICS)))
    payload = hostile_payload(data, genuine)
    before = _counted(opener)
    body = opener.open(topic, payload)
    assert body is None or isinstance(body, dict)
    assert _counted(opener) == before + (body is None)
    opened = Opener(SECRET if with_secret else None, T, RUN.run).open_any_run(topic, payload)
    assert opened is None or (isinstance(opened[0], str) and isinstance(opened[1], dict))


@FUZZ
@given(st.data())
def test_writer_status_is_kept_or_counted_never_raised(data):
    opener = Opener(SECRET, T, RUN.run)
    status = WriterStatus(T, "w2", Sealer(SECRET, T, "writer", "w2", RUN.run), opener)
    msg = hostile_message(data)
    before = _counted(opener)
    is_status = status.receive(msg)
    assert is_status == msg.topic.startswith(T.status_prefix)
    if is_status and msg.payload:
        kept = bool(status._peers)
        assert _counted(opener) == before + (not kept)


@pytest.mark.mqtt
def test_the_collectors_paho_callback_survives_every_mutation(broker):
    with AckCollector(broker.url, BUILD, secret=SECRET, run=RUN) as collector:
        client = collector._conn.client

        @FUZZ
        @given(st.data())
        def deliver(data):
            client.on_message(client, None, hostile_message(data))  # as paho's thread does

        deliver()
        rejected = collector.rejected
    assert "callback_error" not in rejected, rejected
    assert rejected.get("malformed", 0) > 0 and rejected.get("bad_mac", 0) > 0, rejected


def _sample(index: int) -> Sample:
    return Sample(index, {"json": json.dumps({"index": index}).encode(), "bin": bytes(40)})


def _genuine_sample(secret: bytes | None) -> bytes:
    return encode_sample(BUILD, _sample(3), secret, RUN if secret else None)


def _framed(header: bytes, body: bytes = b"") -> bytes:
    msg = struct.pack("<4sHHI", b"DGS1", VERSION, 0, len(header)) + header + body
    return msg + struct.pack("<I", zlib.crc32(msg))


@FUZZ
@given(st.data(), st.booleans())
def test_wire_samples_decode_or_raise_wire_error(data, with_secret):
    secret = SECRET if with_secret else None
    genuine = _genuine_sample(secret)
    kind = data.draw(st.sampled_from(["bytes", "mutated", "header"]))
    if kind == "bytes":
        payload = data.draw(st.binary(max_size=300))
    elif kind == "mutated":
        payload = mutated_bytes(data, genuine)
    else:  # a nasty header framed with a valid CRC: it reaches the header parser
        parts = [{"name": "json", "size": 2}]
        header = {"build_id": BUILD, "index": 3, "key": "000000003", "parts": parts}
        payload = _framed(mutated_json(data, header), b"{}")
    try:
        build_id, sample = decode_sample(payload, 2**20, secret, RUN if secret else None)
    except WireError:
        return
    assert isinstance(build_id, str) and sample.parts


@pytest.fixture(scope="module")
def crashed_writer_dir(tmp_path_factory) -> Path:
    """A writer's directory as a crash leaves it: an open shard journalled twice."""
    out = tmp_path_factory.mktemp("journal") / "ds"
    sink = ShardWriter(out, "0", 10)
    for i in range(4):
        sink.write(_sample(i))
        if i in (1, 3):
            sink.flush_durable()
    return out  # the sink is never closed


ENTRY_VALUES = st.one_of(
    st.integers(-5, 2**31),  # an offset: the code before cut shards "back" to it (1 TiB)
    st.booleans(),
    st.text(max_size=10),
    st.sampled_from(["../../beside", "/etc/passwd", "shard-0-000000.tar", 2**64, 1.5, None]),
)


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@FUZZ
@given(data=st.data())
def test_journals_recover_or_name_the_line(crashed_writer_dir, data):
    lines = journal_path(crashed_writer_dir, "0").read_text().splitlines()
    at = data.draw(st.integers(0, len(lines) - 1))
    how = data.draw(st.sampled_from(["replace", "insert", "bytes", "field"]))
    if how == "bytes":
        new = mutated_bytes(data, lines[at].encode())
    elif how == "field":  # well-formed JSON, a field's value out of range or of another type
        entry = json.loads(lines[at])
        entry[data.draw(st.sampled_from(["shard", "offset", "samples", "closed"]))] = data.draw(
            ENTRY_VALUES
        )
        new = json.dumps(entry).encode()
    else:
        new = mutated_json(data, json.loads(lines[at]))
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        out = root / "ds"
        shutil.copytree(crashed_writer_dir, out)
        (root / "beside").write_bytes(b"not the writer's")
        encoded = [line.encode() for line in lines]
        encoded[at : at + (how != "insert")] = [new]
        journal_path(out, "0").write_bytes(b"\n".join(encoded) + b"\n")
        before = _tree(root)
        keys = durable_keys(out, "0")  # another writer reading it: never raises
        assert keys <= {f"{i:09d}" for i in range(4)}
        try:
            recovered = recover(out, "0")
            assert recovered.keys <= {f"{i:09d}" for i in range(4)}
        except JournalError as exc:
            assert f"journal {journal_path(out, '0')}" in str(exc)  # and the line, or the shard
            assert _tree(root) == before  # refused before touching anything
        after = _tree(root)
        assert {k: v for k, v in after.items() if not k.startswith("ds/")} == {
            k: v for k, v in before.items() if not k.startswith("ds/")
        }
