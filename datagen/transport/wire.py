"""Binary wire format for one sample (version 2); the spec is docs/wire-format.md.

Layout, little-endian::

    b"DGS1" | u16 version | u16 flags | u32 header_len | header (UTF-8 JSON)
    | part payloads, concatenated in header order
    | [32-byte HMAC-SHA256 of everything before it, when flag SIGNED is set]
    | u32 CRC32 of everything before it

A build signs its samples under the key derived from its secret for the purpose ``sample`` and
the run (HKDF-SHA256, ``envelope.derive_key``), so a writer holding the secret rejects
well-formed samples that no worker of the run made (forged, of another build or another run of
it, or signed under another purpose's key or the raw secret). The MAC covers the header, which
names the build, the run, the config's digest, the seed, the index and the key: a genuine
sample cannot be moved into another build or run, or renumbered.

Nothing here unpickles or evaluates anything: a message from the network is bytes,
checked field by field, and either becomes a ``Sample`` or raises ``WireError``.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import struct
import zlib

from datagen.safe_json import JsonInputError, loads_bounded
from datagen.sample import Sample, sample_key, valid_part_name
from datagen.transport.envelope import derive_key
from datagen.transport.run_binding import RunBinding

MAGIC = b"DGS1"
VERSION = 2  # 1: signed samples named no run
# magic(4s) version(u16) flags(u16) header_len(u32): 12 bytes
_PREFIX = struct.Struct("<4sHHI")
_CRC = struct.Struct("<I")
MIN_MESSAGE_BYTES = _PREFIX.size + _CRC.size
FLAG_SIGNED = 0x0001
KNOWN_FLAGS = FLAG_SIGNED
MAC_BYTES = 32  # HMAC-SHA256
MAX_HEADER_BYTES = 2**20  # a header names a few parts; JSON nesting is bounded too (safe_json)
# Default upper bound for one encoded sample; broker and clients are configured with it.
DEFAULT_MAX_MESSAGE_BYTES = 64 * 2**20


SECRET_ENV = "DATAGEN_BUILD_SECRET"  # hex; shared by a build's coordinator and its writers
SAMPLE_PURPOSE = "sample"  # HKDF info of the key that signs samples


def parse_secret(text: str) -> bytes:
    """A build secret from hex text (at least 16 bytes)."""
    try:
        secret = bytes.fromhex(text.strip())
    except ValueError:
        raise ValueError(f"${SECRET_ENV} must be hex digits") from None
    if len(secret) < 16:
        raise ValueError(f"${SECRET_ENV} must hold at least 16 bytes (32 hex digits)")
    return secret


class WireError(ValueError):
    """A payload is not a valid version-1 sample message; the text says why."""


def sample_mac(secret: bytes, run: str, *signed: bytes | memoryview) -> bytes:
    """HMAC-SHA256, under the ``sample`` key of the build secret in run ``run``, of the bytes
    before the MAC (``signed``: them, in pieces or whole)."""
    mac = hmac.new(derive_key(secret, SAMPLE_PURPOSE, run), digestmod=hashlib.sha256)
    for piece in signed:
        mac.update(piece)
    return mac.digest()


def encode_sample(
    build_id: str, sample: Sample, secret: bytes | None = None, run: RunBinding | None = None
) -> bytes:
    """``secret``: the build secret (raw bytes) and ``run`` the run the sample is made in; the
    header then names the run, and the message carries the HMAC-SHA256 of ``sample_mac``."""
    if not isinstance(build_id, str) or not build_id:
        raise WireError("build_id must be a non-empty string")
    if secret and run is None:
        raise WireError("a signed sample names its run: give the run it was made in")
    if not sample.parts:
        raise WireError(f"sample {sample.key} has no parts")
    for name, data in sample.parts.items():
        if not isinstance(name, str) or not valid_part_name(name):
            raise WireError(f"sample {sample.key}: invalid part name {name!r}")
        if not isinstance(data, bytes | bytearray | memoryview):
            raise WireError(
                f"sample {sample.key}: part {name!r} is {type(data).__name__}, not bytes"
            )
    header = {
        "build_id": build_id,
        **(run.fields() if run is not None else {}),
        "index": sample.index,
        "key": sample.key,
        "parts": [{"name": name, "size": len(data)} for name, data in sample.parts.items()],
    }
    header_bytes = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    flags = FLAG_SIGNED if secret else 0
    pieces = [_PREFIX.pack(MAGIC, VERSION, flags, len(header_bytes)), header_bytes]
    pieces += sample.parts.values()
    if secret and run is not None:
        pieces.append(sample_mac(secret, run.run, *pieces))
    crc = 0
    for piece in pieces:
        crc = zlib.crc32(piece, crc)
    # one message-sized copy: the MAC and the CRC are computed over the pieces (a 1.3 MB
    # sample's two extra copies cost 0.8 ms of its 2.3 ms to encode)
    return b"".join([*pieces, _CRC.pack(crc)])


def decode_sample(
    payload: bytes | bytearray,
    max_bytes: int | None = None,
    secret: bytes | None = None,
    run: RunBinding | None = None,
) -> tuple[str, Sample]:
    """Checks and decodes one message; returns (build_id, sample) or raises ``WireError``.

    With ``secret`` (the build secret, raw bytes), only messages signed under its ``sample`` key
    in the run their header names are accepted; with ``run`` too, only those of that run (its
    id, config digest and seed).
    """
    payload = bytes(payload)
    n = len(payload)
    if max_bytes is not None and n > max_bytes:
        raise WireError(f"message of {n} bytes exceeds the limit of {max_bytes} bytes")
    if n < MIN_MESSAGE_BYTES:
        raise WireError(f"truncated: {n} bytes is shorter than the {MIN_MESSAGE_BYTES}-byte frame")
    magic, version, flags, header_len = _PREFIX.unpack_from(payload, 0)
    if magic != MAGIC:
        raise WireError(f"bad magic {magic!r}, expected {MAGIC!r}")
    if version != VERSION:
        raise WireError(
            f"unknown wire version {version}, this decoder reads version {VERSION} (the workers "
            "and writers of a build must run the same datagen)"
        )
    if flags & ~KNOWN_FLAGS:
        raise WireError(f"unknown flags 0x{flags:04x} (version 2 defines only 0x0001, signed)")
    mac_len = MAC_BYTES if flags & FLAG_SIGNED else 0
    header_end = _PREFIX.size + header_len
    if header_end > n - _CRC.size - mac_len:
        raise WireError(
            f"truncated: header_len {header_len} runs past the end of a {n}-byte message"
        )
    # A signed message's MAC covers every byte its CRC does but the MAC itself: when the MAC
    # verifies, the CRC is not computed (2.7 ms of a writer's 14 ms per 1.5 MiB sample); when
    # anything fails, a CRC mismatch is reported first, as corruption rather than forgery.
    signed = secret is not None and bool(mac_len)
    if not signed:
        _check_crc(payload)
    try:
        build_id, index, parts, claimed = _parse_header(payload[_PREFIX.size : header_end])
        if secret is not None:
            if not mac_len:
                raise WireError(
                    "unsigned sample: this build accepts only samples signed with its secret"
                )
            if claimed is None:
                raise WireError("signed sample names no run (header.run): not made by a worker")
            signed_end = n - _CRC.size - mac_len
            expected = sample_mac(secret, claimed.run, memoryview(payload)[:signed_end])
            if not hmac.compare_digest(expected, payload[signed_end : signed_end + mac_len]):
                raise WireError("signature does not verify: not made by a worker of this build")
    except WireError:
        if signed:
            _check_crc(payload)
        raise
    if secret is not None and run is not None and (why := run.mismatch(claimed)) is not None:
        raise WireError(f"a genuine sample of another run of this build, replayed: {why}")
    body_len = n - _CRC.size - mac_len - header_end
    total = sum(size for _, size in parts)
    if total != body_len:
        raise WireError(f"part sizes add up to {total} bytes but the body holds {body_len}")
    data: dict[str, bytes] = {}
    offset = header_end
    for name, size in parts:
        data[name] = payload[offset : offset + size]
        offset += size
    return build_id, Sample(index=index, parts=data)


def _check_crc(payload: bytes) -> None:
    n = len(payload)
    (crc,) = _CRC.unpack_from(payload, n - _CRC.size)
    actual = zlib.crc32(memoryview(payload)[: n - _CRC.size])
    if crc != actual:
        raise WireError(f"CRC32 mismatch: message says 0x{crc:08x}, content gives 0x{actual:08x}")


def _parse_header(raw: bytes) -> tuple[str, int, list[tuple[str, int]], RunBinding | None]:
    try:
        header = loads_bounded(raw, what="header", max_bytes=MAX_HEADER_BYTES)
    except JsonInputError as exc:
        raise WireError(str(exc)) from None
    if not isinstance(header, dict):
        raise WireError(f"header is a JSON {type(header).__name__}, expected an object")
    build_id = header.get("build_id")
    index = header.get("index")
    key = header.get("key")
    parts = header.get("parts")
    if not isinstance(build_id, str) or not build_id:
        raise WireError("header.build_id must be a non-empty string")
    if not _is_int(index):
        raise WireError("header.index must be an integer")
    try:
        expected_key = sample_key(index)
    except ValueError as exc:
        raise WireError(f"header.index: {exc}") from None
    if key != expected_key:
        raise WireError(
            f"header.key {key!r} does not match index {index} (expected {expected_key!r})"
        )
    if not isinstance(parts, list) or not parts:
        raise WireError("header.parts must be a non-empty list")
    out: list[tuple[str, int]] = []
    seen: set[str] = set()
    for i, part in enumerate(parts):
        if not isinstance(part, dict):
            raise WireError(f"header.parts[{i}] must be an object")
        name, size = part.get("name"), part.get("size")
        if not isinstance(name, str) or not valid_part_name(name):
            raise WireError(f"header.parts[{i}].name {name!r} is not a valid part name")
        if name in seen:
            raise WireError(f"header.parts: duplicate part name {name!r}")
        if not _is_int(size) or size < 0:
            raise WireError(f"header.parts[{i}].size must be a non-negative integer")
        seen.add(name)
        out.append((name, size))
    try:
        claimed = RunBinding.from_fields(header, "header") if "run" in header else None
    except ValueError as exc:
        raise WireError(str(exc)) from None
    return build_id, index, out, claimed


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
