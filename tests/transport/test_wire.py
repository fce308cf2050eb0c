from __future__ import annotations

import hashlib
import hmac
import json
import re
import struct
import zlib
from pathlib import Path

import pytest

from datagen.sample import Sample
from datagen.transport.envelope import derive_key
from datagen.transport.run_binding import RunBinding
from datagen.transport.topics import ack_indices, topics
from datagen.transport.wire import MAGIC, WireError, decode_sample, encode_sample

REPO = Path(__file__).resolve().parents[2]


def frame(
    header: object, body: bytes = b"", *, magic=MAGIC, version=2, flags=0, header_bytes=None
) -> bytes:
    """A message with a valid CRC around arbitrary (possibly wrong) contents."""
    h = header_bytes if header_bytes is not None else json.dumps(header).encode()
    msg = struct.pack("<4sHHI", magic, version, flags, len(h)) + h + body
    return msg + struct.pack("<I", zlib.crc32(msg))


def header(**override) -> dict:
    h = {"build_id": "b1", "index": 3, "key": "000000003", "parts": [{"name": "json", "size": 2}]}
    h.update(override)
    return h


def test_round_trip(make_sample):
    sample = make_sample(42)
    build_id, out = decode_sample(encode_sample("build-1", sample))
    assert build_id == "build-1"
    assert out.index == 42 and out.key == "000000042"
    assert out.parts == sample.parts
    assert list(out.parts) == list(sample.parts)


def test_encoding_is_deterministic_and_empty_parts_allowed():
    s = Sample(0, {"json": b"{}", "empty.bin": b""})
    assert encode_sample("b", s) == encode_sample("b", s)
    assert decode_sample(encode_sample("b", s))[1].parts == s.parts


def test_spec_example_matches_encoder():
    doc = (REPO / "docs" / "wire-format.md").read_text()
    hex_line = re.search(r"<!-- wire-example -->\n```\n([0-9a-f]+)\n```", doc)[1]
    expected = encode_sample("demo", Sample(7, {"json": b'{"n":1}', "note.txt": b"hi"}))
    assert bytes.fromhex(hex_line) == expected


def test_valid_frame_helper_decodes():
    assert decode_sample(frame(header(), b"{}"))[1].parts == {"json": b"{}"}


@pytest.mark.parametrize(
    ("payload", "reason"),
    [
        (b"", "truncated"),
        (b"DGS1\x01\x00", "truncated"),
        (frame(header(), b"{}", magic=b"XXXX"), "bad magic"),
        (frame(header(), b"{}", version=1), "unknown wire version 1, this decoder reads version 2"),
        (frame(header(), b"{}", flags=2), "unknown flags"),
        (frame(header(), b"{}", flags=1), "truncated"),  # signed, but no room for the MAC
        (frame(header(), b"{}")[:-1], "CRC32 mismatch"),
        (frame(header(), b"{}")[:-3] + b"\x00\x00\x00", "CRC32 mismatch"),
        (frame(None, header_bytes=b"\xff\xfe"), "header: not valid JSON"),
        (frame(None, header_bytes=b"{not json"), "header: not valid JSON"),
        (frame([1, 2]), "expected an object"),
        (frame(header(build_id=7), b"{}"), "build_id"),
        (frame(header(build_id=""), b"{}"), "build_id"),
        (frame(header(index="3"), b"{}"), "index must be an integer"),
        (frame(header(index=True), b"{}"), "index must be an integer"),
        (frame(header(index=-1, key="x"), b"{}"), "out of range"),
        (frame(header(key="3"), b"{}"), "does not match index"),
        (frame(header(parts=[]), b""), "non-empty list"),
        (frame(header(parts={"json": 2}), b"{}"), "non-empty list"),
        (frame(header(parts=["json"]), b"{}"), "must be an object"),
        (frame(header(parts=[{"name": "../etc", "size": 2}]), b"{}"), "not a valid part name"),
        (frame(header(parts=[{"name": "JSON", "size": 2}]), b"{}"), "not a valid part name"),
        (frame(header(parts=[{"name": 5, "size": 2}]), b"{}"), "not a valid part name"),
        (frame(header(parts=[{"name": "json", "size": -2}]), b"{}"), "non-negative integer"),
        (frame(header(parts=[{"name": "json", "size": 2.0}]), b"{}"), "non-negative integer"),
        (
            frame(header(parts=[{"name": "json", "size": 1}, {"name": "json", "size": 1}]), b"{}"),
            "duplicate part name",
        ),
        (frame(header(), b"{}x"), "add up to 2 bytes but the body holds 3"),
        (frame(header(), b"{"), "add up to 2 bytes but the body holds 1"),
    ],
)
def test_malformed_messages_are_rejected(payload, reason):
    with pytest.raises(WireError, match=re.escape(reason)):
        decode_sample(payload)


def test_header_len_past_end_is_truncation():
    msg = bytearray(frame(header(), b"{}"))
    struct.pack_into("<I", msg, 8, 10**6)
    with pytest.raises(WireError, match="runs past the end"):
        decode_sample(bytes(msg))


def test_oversize_is_rejected_before_parsing():
    msg = encode_sample("b", Sample(1, {"json": b"x" * 1000}))
    assert decode_sample(msg, max_bytes=len(msg))[1].index == 1
    with pytest.raises(WireError, match="exceeds the limit"):
        decode_sample(msg, max_bytes=len(msg) - 1)


@pytest.mark.parametrize(
    ("build_id", "sample", "reason"),
    [
        ("", Sample(0, {"json": b"{}"}), "build_id"),
        ("b", Sample(0, {}), "no parts"),
        ("b", Sample(0, {"Bad Name": b""}), "invalid part name"),
        ("b", Sample(0, {"json": "text"}), "not bytes"),
    ],
)
def test_encoder_refuses_invalid_samples(build_id, sample, reason):
    with pytest.raises(WireError, match=reason):
        encode_sample(build_id, sample)


@pytest.mark.parametrize(
    ("ack", "indices"),
    [
        ({"key": "000000007", "index": 7, "writer": "0"}, [7]),
        ({"indices": [1, 2, 900], "writer": "A"}, [1, 2, 900]),
        ({"indices": [], "writer": "A"}, []),
        ({"key": "000000008", "index": 7}, None),  # key does not match
        ({"index": True, "key": "000000001"}, None),  # booleans are not integers
        ({"indices": [1, -2]}, None),
        ({"indices": [10**9]}, None),
        ({"indices": "1,2"}, None),
        ({"index": 10**9, "key": "1000000000"}, None),
        ([7], None),
    ],
)
def test_ack_messages_in_both_forms(ack, indices):
    assert ack_indices(ack) == indices


def test_topics_of_a_build():
    t = topics("b1")
    assert (t.samples, t.acks, t.control) == (
        "datagen/b1/samples",
        "datagen/b1/acks",
        "datagen/b1/control",
    )
    assert t.status("A") == "datagen/b1/status/A" and t.status_all == "datagen/b1/status/+"
    assert t.shared_samples == "$share/datagen-b1/datagen/b1/samples"


def test_signed_samples_verify_only_with_the_builds_secret():
    from datagen.transport.wire import FLAG_SIGNED

    secret, other = b"s" * 32, b"o" * 32
    sample = Sample(5, {"json": b'{"a":1}', "rgb.png": b"\x89PNG..."})
    payload = encode_sample("b1", sample, secret, DOC_RUN)
    assert int.from_bytes(payload[6:8], "little") == FLAG_SIGNED
    build_id, decoded = decode_sample(payload, secret=secret, run=DOC_RUN)
    assert build_id == "b1" and decoded.parts == sample.parts
    assert decode_sample(payload)[1].parts == sample.parts  # readable without verifying
    with pytest.raises(WireError, match="signature does not verify"):
        decode_sample(payload, secret=other)
    with pytest.raises(WireError, match="unsigned sample"):
        decode_sample(encode_sample("b1", sample), secret=secret)
    tampered = bytearray(payload)
    tampered[-40] ^= 1  # inside the MAC; recompute the CRC so only the signature can catch it

    tampered[-4:] = zlib.crc32(bytes(tampered[:-4])).to_bytes(4, "little")
    with pytest.raises(WireError, match="signature does not verify"):
        decode_sample(bytes(tampered), secret=secret)


DOC_SECRET = bytes(range(32))  # the secret of docs/wire-format.md's signed example
DOC_RUN = RunBinding("0123456789abcdef0123456789abcdef", hashlib.sha256(b"{}").hexdigest(), 7)


def _doc_value(tag: str) -> str:
    doc = (REPO / "docs" / "wire-format.md").read_text()
    found = re.search(rf"<!-- {tag} -->(?:\n```\n([0-9a-f]+)\n```|`([0-9a-f]+)`)", doc)
    assert found, f"docs/wire-format.md has no value tagged <!-- {tag} -->"
    return found[1] or found[2]


def _documented_decoder(hex_line: str, secret: bytes | None) -> dict[str, bytes]:
    """Runs the Python decoder printed in docs/wire-format.md, as printed."""
    doc = (REPO / "docs" / "wire-format.md").read_text()
    code = re.search(r"<!-- wire-decoder -->\n```python\n(.*?)```", doc, re.S)[1]
    scope = {"hex_line": hex_line, "secret": secret}
    exec(code, scope)
    return scope["parts"]


def test_signed_spec_example_is_the_encoders_test_vector():
    sample = Sample(7, {"json": b'{"n":1}', "note.txt": b"hi"})
    signed = encode_sample("demo", sample, DOC_SECRET, DOC_RUN)
    assert signed.hex() == _doc_value("wire-example-signed")
    assert derive_key(DOC_SECRET, "sample", DOC_RUN.run).hex() == _doc_value("sample-key")
    assert signed[-36:-4].hex() == _doc_value("sample-mac")
    assert decode_sample(signed, secret=DOC_SECRET, run=DOC_RUN)[1].parts == sample.parts


def test_the_documented_decoder_verifies_as_the_writer_does():
    signed, unsigned = _doc_value("wire-example-signed"), _doc_value("wire-example")
    assert _documented_decoder(signed, DOC_SECRET) == {"json": b'{"n":1}', "note.txt": b"hi"}
    assert _documented_decoder(unsigned, None) == {"json": b'{"n":1}', "note.txt": b"hi"}
    with pytest.raises(AssertionError, match="not signed by this build"):
        _documented_decoder(signed, bytes(32))
    with pytest.raises(AssertionError, match="unsigned"):
        _documented_decoder(unsigned, DOC_SECRET)


def _signed_with(key: bytes, sample: Sample, build_id: str = "b1") -> bytes:
    """A sample of run DOC_RUN whose MAC is HMAC-SHA256 under ``key`` itself (no HKDF)."""
    body = bytearray(encode_sample(build_id, sample, run=DOC_RUN)[:-4])
    body[6] = 1  # flags: signed
    body += hmac.new(key, bytes(body), hashlib.sha256).digest()
    return bytes(body) + zlib.crc32(body).to_bytes(4, "little")


def test_only_the_sample_key_of_the_secret_in_the_run_verifies_a_sample():
    secret, run = DOC_SECRET, DOC_RUN.run
    sample = Sample(1, {"json": b"{}"})
    genuine = encode_sample("b1", sample, secret, DOC_RUN)
    assert _signed_with(derive_key(secret, "sample", run), sample) == genuine
    other_run = "f" * 32
    for wrong in (
        secret,
        derive_key(secret, "sample"),  # the key of no run (wire version 1)
        derive_key(secret, "sample", other_run),
        derive_key(secret, "ack", run),
        derive_key(secret, "control", run),
    ):
        with pytest.raises(WireError, match="signature does not verify"):
            decode_sample(_signed_with(wrong, sample), secret=secret)
    renumbered = bytearray(
        genuine.replace(b'"index":1,"key":"000000001"', b'"index":2,"key":"000000002"')
    )
    assert renumbered != genuine
    renumbered[-4:] = zlib.crc32(bytes(renumbered[:-4])).to_bytes(4, "little")  # a valid CRC
    with pytest.raises(WireError, match="signature does not verify"):
        decode_sample(bytes(renumbered), secret=secret)


def test_a_genuine_sample_of_another_run_is_refused_as_a_replay():
    sample = Sample(1, {"json": b'{"seed": 7, "index": 1}'})
    earlier = RunBinding.draw({}, 7)
    replayed = encode_sample("b1", sample, DOC_SECRET, earlier)
    assert decode_sample(replayed, secret=DOC_SECRET)[1].parts == sample.parts  # genuine
    with pytest.raises(WireError, match=rf"another run .*run {earlier.run} is not this run"):
        decode_sample(replayed, secret=DOC_SECRET, run=DOC_RUN)
    other_seed = RunBinding(DOC_RUN.run, DOC_RUN.config_sha256, 8)
    with pytest.raises(WireError, match="seed 8 is not this build's seed 7"):
        decode_sample(
            encode_sample("b1", sample, DOC_SECRET, other_seed), secret=DOC_SECRET, run=DOC_RUN
        )
    with pytest.raises(WireError, match="a signed sample names its run"):
        encode_sample("b1", sample, DOC_SECRET)
    assert DOC_RUN.metadata_mismatch({"seed": 6, "index": 1}, 1) == (
        "metadata seed 6 is not this build's seed 7"
    )
    assert DOC_RUN.metadata_mismatch({"seed": 7, "index": 2}, 1).startswith("metadata index 2")
