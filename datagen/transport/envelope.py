"""Signed control-plane messages: acks, status and control commands (docs/wire-format.md,
"Control-plane messages").

With the build secret, every JSON message on a build's ``acks``, ``status/<writer>`` and
``control`` topics travels in an envelope::

    {"v": 2, "build": BUILD_ID, "run": RUN, "topic": TOPIC, "role": "writer"|"coordinator",
     "sender": ID, "session": HEX, "seq": N, "body": {...}, "mac": HEX}

``mac`` is HMAC-SHA256, under a key derived for the topic's purpose (``ack``, ``status``,
``control``) and the run from the raw 32-byte secret with HKDF-SHA256, of the canonical JSON
(sorted keys, no spaces, UTF-8) of every other field. ``run`` is the id of the coordinator's run
the message belongs to (``run_binding``), or "" for what a writer says before a run binds it.
A receiver drops, and counts, what is unsigned, of another envelope version, wrongly signed,
for another build, run or topic, from a role that may not send there, sent in another sender's
name, or replayed (a sequence number not above the last one seen from that sender's session).
Without a secret (a writer started without ``$DATAGEN_BUILD_SECRET``) messages are the bare
bodies and nothing is checked.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import secrets
import threading
from collections import Counter
from typing import Any

from datagen.safe_json import JsonInputError, loads_bounded
from datagen.transport.run_binding import valid_run_id
from datagen.transport.topics import Topics

VERSION = 2  # 1: no run (before runs were bound)
HKDF_SALT = b"datagen control plane v1"
ROLES = {"ack": ("writer",), "status": ("writer",), "control": ("coordinator",)}
# Bounds of one message, envelope included, by purpose; larger ones are dropped as malformed.
# A batched ack holds at most 10 000 indices (~110 KB); a finalize command carries the manifest.
MAX_MESSAGE_BYTES = {"ack": 2**20, "status": 2**20, "control": 64 * 2**20}


def hkdf_sha256(ikm: bytes, salt: bytes, info: bytes) -> bytes:
    """RFC 5869 HKDF with SHA-256, 32 bytes of output (one block)."""
    prk = hmac.new(salt, ikm, hashlib.sha256).digest()
    return hmac.new(prk, info + b"\x01", hashlib.sha256).digest()


def derive_key(secret: bytes, purpose: str, run: str = "") -> bytes:
    """The key for ``purpose`` (``sample``, ``ack``, ``status``, ``control``) in run ``run``
    (32 hex digits; "" outside any run) from the raw secret bytes: HKDF info ``purpose`` or
    ``purpose:run``. Samples use theirs in ``wire``."""
    info = f"{purpose}:{run}" if run else purpose
    return hkdf_sha256(secret, HKDF_SALT, info.encode("ascii"))


class RunKeys:
    """The keys of one secret, by purpose and run; the runs' keys are kept for the current
    run and the one outside any run (others, a replay's, are derived when needed)."""

    def __init__(self, secret: bytes):
        self._secret = secret
        self._kept: dict[tuple[str, str], bytes] = {}

    def key(self, purpose: str, run: str, keep: bool) -> bytes:
        found = self._kept.get((purpose, run))
        if found is None:
            found = derive_key(self._secret, purpose, run)
            if keep:
                self._kept[(purpose, run)] = found
        return found


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
    """Signs the messages one sender (a writer, or the coordinator) publishes, for run ``run``
    ("" until a writer is bound to one; a writer sets it when a ``bind`` command binds it)."""

    def __init__(
        self, secret: bytes | None, build_topics: Topics, role: str, sender: str, run: str = ""
    ):
        self.secret, self.topics, self.role, self.sender = secret, build_topics, role, sender
        self.run = run
        self.session = secrets.token_hex(8)
        self._seq = 0
        self._lock = threading.Lock()
        self._keys = RunKeys(secret) if secret else None

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
            run = self.run
            key = self._keys.key(purpose, run, keep=True)
        fields = {
            "v": VERSION,
            "build": self.topics.build_id,
            "run": run,
            "topic": topic,
            "role": self.role,
            "sender": self.sender,
            "session": session or self.session,
            "seq": seq,
            "body": body,
        }
        mac = hmac.new(key, canonical(fields), hashlib.sha256).hexdigest()
        return canonical(fields | {"mac": mac})


class Opener:
    """Checks what arrives on a build's control-plane topics; ``rejected`` counts the drops by
    reason (``unsigned``, ``malformed``, ``wrong_version``, ``bad_mac``, ``wrong_build``,
    ``wrong_run``, ``wrong_topic``, ``wrong_role``, ``wrong_sender``, ``replayed``, and the
    receivers' own: ``stale_bind``).

    ``run`` is the run a message must belong to ("" until a writer is bound): ``open`` drops
    the others, counting those of another run (a recording of an earlier run replayed) and
    silently dropping those outside any run (writers that wait for their bind, counted in
    ``outside_run``). ``open_any_run`` leaves that choice to the caller."""

    def __init__(self, secret: bytes | None, build_topics: Topics, run: str = ""):
        self.secret, self.topics, self.run = secret, build_topics, run
        self._keys = RunKeys(secret) if secret else None
        self._last: dict[tuple[str, str, str], int] = {}
        self._lock = threading.RLock()  # _drop is also called with it held
        self.rejected: Counter[str] = Counter()
        self.duplicates = 0  # the same genuine message again (QoS 1 redelivery, retained)
        self.outside_run = 0  # genuine, of a writer not bound to a run yet: not for us

    def reject(self, reason: str) -> None:
        """Counts a message a receiver dropped after opening it (a ``stale_bind``...)."""
        self._drop(reason)

    def open(self, topic: str, payload: bytes | bytearray) -> dict[str, Any] | None:
        """The body of a message of the current run, or None (dropped; counted, unless it is
        a duplicate or outside any run)."""
        opened = self.open_any_run(topic, payload)
        if opened is None:
            return None
        run, body = opened
        if run == self.run:
            return body
        if run == "":
            with self._lock:
                self.outside_run += 1
            return None
        return self._drop("wrong_run")

    def open_any_run(
        self, topic: str, payload: bytes | bytearray
    ) -> tuple[str, dict[str, Any]] | None:
        """(the run it belongs to, the body) of a genuine message of any run, or None (dropped
        and counted). Without a secret every message is of the current run."""
        limit = MAX_MESSAGE_BYTES.get(purpose_of(self.topics, topic) or "", 2**20)
        try:
            message = loads_bounded(payload, what=f"message on {topic}", max_bytes=limit)
        except JsonInputError:
            return self._drop("malformed")
        if not self.secret:
            return (self.run, message) if isinstance(message, dict) else self._drop("malformed")
        if not isinstance(message, dict) or "mac" not in message:
            return self._drop("unsigned")
        if message.get("v") != VERSION:
            return self._drop("wrong_version")
        purpose = purpose_of(self.topics, topic)
        fields = {k: v for k, v in message.items() if k != "mac"}
        mac, run = message["mac"], message.get("run")
        if purpose is None or not isinstance(mac, str) or not valid_run_id(run):
            return self._drop("malformed")
        key = self._keys.key(purpose, run, keep=run in (self.run, ""))
        expected = hmac.new(key, canonical(fields), hashlib.sha256).hexdigest()
        if not hmac.compare_digest(mac.encode("utf-8"), expected.encode("ascii")):
            return self._drop("bad_mac")
        body = self._check(topic, purpose, fields)
        return None if body is None else (run, body)

    def _check(self, topic: str, purpose: str, fields: dict[str, Any]) -> dict[str, Any] | None:
        body, sender, seq = fields.get("body"), fields.get("sender"), fields.get("seq")
        if not isinstance(body, dict) or not isinstance(seq, int):
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
