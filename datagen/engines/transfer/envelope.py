"""Signed control-plane messages: acks, status and control commands (docs/wire-format.md,
"Control-plane messages").

With the build secret, every JSON message on a build's ``acks``, ``status/<writer>`` and
``control`` topics travels in an envelope::

    {"v": 1, "build": BUILD_ID, "topic": TOPIC, "role": "writer"|"coordinator",
     "sender": ID, "session": HEX, "seq": N, "body": {...}, "mac": HEX}

``mac`` is HMAC-SHA256, under a key derived for the topic's purpose (``ack``, ``status``,
``control``) from the raw 32-byte secret with HKDF-SHA256, of the canonical JSON (sorted keys,
no spaces, UTF-8) of every other field. A receiver drops, and counts, what is unsigned, wrongly
signed, for another build or topic, from a role that may not send there, sent in another
sender's name, or replayed (a sequence number not above the last one seen from that sender's
session). Without a secret (a writer started without ``$DATAGEN_BUILD_SECRET``) messages are
the bare bodies, as in wire version 1, and nothing is checked.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import secrets
import threading
from collections import Counter
from typing import Any

from datagen.engines.transfer.topics import Topics

VERSION = 1
HKDF_SALT = b"datagen control plane v1"
ROLES = {"ack": ("writer",), "status": ("writer",), "control": ("coordinator",)}


def hkdf_sha256(ikm: bytes, salt: bytes, info: bytes) -> bytes:
    """RFC 5869 HKDF with SHA-256, 32 bytes of output (one block)."""
    prk = hmac.new(salt, ikm, hashlib.sha256).digest()
    return hmac.new(prk, info + b"\x01", hashlib.sha256).digest()


def derive_key(secret: bytes, purpose: str) -> bytes:
    """The key for ``purpose`` (``sample``, ``ack``, ``status``, ``control``) from the raw
    secret bytes; samples use theirs in ``wire``."""
    return hkdf_sha256(secret, HKDF_SALT, purpose.encode("ascii"))


def canonical(fields: dict[str, Any]) -> bytes:
    return json.dumps(fields, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode()


def purpose_of(build_topics: Topics, topic: str) -> str | None:
    if topic == build_topics.acks:
        return "ack"
    if topic == build_topics.control:
        return "control"
    if topic.startswith(build_topics.status_prefix):
        return "status"
    return None


class Sealer:
    """Signs the messages one sender (a writer, or the coordinator) publishes."""

    def __init__(self, secret: bytes | None, build_topics: Topics, role: str, sender: str):
        self.secret, self.topics, self.role, self.sender = secret, build_topics, role, sender
        self.session = secrets.token_hex(8)
        self._seq = 0
        self._lock = threading.Lock()
        self._keys = {p: derive_key(secret, p) for p in ROLES} if secret else {}

    def seal(self, topic: str, body: dict[str, Any], session: str | None = None) -> bytes:
        """The payload for ``body`` on ``topic``; ``session`` gives a separate sequence (the
        will, which the broker publishes later, after messages with higher numbers)."""
        if not self.secret:
            return json.dumps(body, separators=(",", ":")).encode("utf-8")
        purpose = purpose_of(self.topics, topic)
        if purpose is None:
            raise ValueError(f"{topic} is not a control-plane topic of this build")
        with self._lock:
            self._seq += 1
            seq = 1 if session else self._seq
        fields = {
            "v": VERSION, "build": self.topics.build_id, "topic": topic, "role": self.role,
            "sender": self.sender, "session": session or self.session, "seq": seq, "body": body,
        }  # fmt: skip
        mac = hmac.new(self._keys[purpose], canonical(fields), hashlib.sha256).hexdigest()
        return canonical(fields | {"mac": mac})


class Opener:
    """Checks what arrives on a build's control-plane topics; ``rejected`` counts the drops by
    reason (``unsigned``, ``malformed``, ``bad_mac``, ``wrong_build``, ``wrong_topic``,
    ``wrong_role``, ``wrong_sender``, ``replayed``)."""

    def __init__(self, secret: bytes | None, build_topics: Topics):
        self.secret, self.topics = secret, build_topics
        self._keys = {p: derive_key(secret, p) for p in ROLES} if secret else {}
        self._last: dict[tuple[str, str, str], int] = {}
        self._lock = threading.RLock()  # _drop is also called with it held
        self.rejected: Counter[str] = Counter()
        self.duplicates = 0  # the same genuine message again (QoS 1 redelivery, retained)

    def open(self, topic: str, payload: bytes) -> dict[str, Any] | None:
        """The body, or None (dropped and counted)."""
        try:
            message = json.loads(payload)
        except ValueError:
            return self._drop("malformed")
        if not self.secret:
            return message if isinstance(message, dict) else self._drop("malformed")
        if not isinstance(message, dict) or "mac" not in message:
            return self._drop("unsigned")
        purpose = purpose_of(self.topics, topic)
        fields = {k: v for k, v in message.items() if k != "mac"}
        mac = message["mac"]
        if purpose is None or not isinstance(mac, str):
            return self._drop("malformed")
        expected = hmac.new(self._keys[purpose], canonical(fields), hashlib.sha256).hexdigest()
        if not hmac.compare_digest(mac, expected):
            return self._drop("bad_mac")
        return self._check(topic, purpose, fields)

    def _check(self, topic: str, purpose: str, fields: dict[str, Any]) -> dict[str, Any] | None:
        body, sender, seq = fields.get("body"), fields.get("sender"), fields.get("seq")
        if fields.get("v") != VERSION or not isinstance(body, dict) or not isinstance(seq, int):
            return self._drop("malformed")
        if fields.get("build") != self.topics.build_id:
            return self._drop("wrong_build")
        if fields.get("topic") != topic:
            return self._drop("wrong_topic")
        if fields.get("role") not in ROLES[purpose]:
            return self._drop("wrong_role")
        named = topic[len(self.topics.status_prefix) :] if purpose == "status" else None
        if purpose == "ack":
            named = body.get("writer")
        if named is not None and named != sender:
            return self._drop("wrong_sender")
        stream = (str(fields.get("role")), str(sender), str(fields.get("session")))
        with self._lock:
            last = self._last.get(stream, 0)
            if seq == last:
                self.duplicates += 1
                return None
            if seq < last:
                return self._drop("replayed")
            self._last[stream] = seq
        return body

    def _drop(self, reason: str) -> None:
        with self._lock:
            self.rejected[reason] += 1
        return None
