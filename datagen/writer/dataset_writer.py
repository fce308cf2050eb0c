"""The dataset-writer process: MQTT samples in, durable WebDataset shards out.

``datagen writer --broker URL --build-id ID --out DIR [--writer-id W]`` (options:
``datagen/cli/service_commands.py``, which also sets up its log and signals) runs a
``DatasetWriter``. Several writers may serve one build, into one directory (same machine or a
shared file system), each with its own ``--writer-id``: they share the samples through an MQTT
v5 shared subscription, so each sample reaches one of them.

Sessions: persistent (fixed client id, clean_start=False) with a bounded expiry
(``--session-expiry``, default 60 s): a writer restarted within it gets the samples the broker
held for it; one that never returns stops swallowing its share of the samples when the broker
expires its session (docs/mqtt-pitfalls.md, pitfall 3), and the coordinator re-issues what was
held. A clean stop (SIGTERM/SIGINT, or a finished build) unsubscribes, finishes what was
delivered and ends the session, so nothing more is routed to it.

On start a writer repairs its shards, then acks every sample durable in the directory (all
writers' shards, in batches) before announcing ``ready``; with the build secret it first waits
(``waiting``) for the coordinator's ``bind`` to a run, and only then acks and takes samples
(``datagen/writer/binding.py``). ``finalize``: see
``datagen/writer/finalize_round.py``, ``datagen/writer/finalize.py`` and docs/wire-format.md.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Set as AbstractSet
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt

from datagen.errors import disk_full_message, is_disk_full
from datagen.safe_json import loads_bounded
from datagen.sample import Sample
from datagen.shards import valid_writer_id
from datagen.transport.envelope import Opener, Sealer
from datagen.transport.run_binding import writer_client_id
from datagen.transport.topics import topics
from datagen.transport.wire import (
    DEFAULT_MAX_MESSAGE_BYTES,
    WireError,
    decode_sample,
)
from datagen.writer.acks import announce, others_acked_keys
from datagen.writer.binding import WriterBinding
from datagen.writer.durable_samples import DurableSamples
from datagen.writer.finalize_round import finalize_args, run_round
from datagen.writer.links import WriterLinks
from datagen.writer.lock import WriterLock, WriterLocked
from datagen.writer.status import WriterStatus

log = logging.getLogger("datagen.writer")

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_FINALIZE_MISMATCH = 3  # finalize refused (count mismatch, a writer missing): no manifest
EXIT_LOCKED = 4  # another process runs this writer id on this directory
EXIT_DISK_FULL = 5  # its disk is full: not restarted; what is durable stays for --resume

DEFAULT_SESSION_EXPIRY_S = 60
DRAIN_TIMEOUT_S = 10.0
DRAIN_QUIET_S = 0.5


class DatasetWriter:
    """One writer of a build: takes samples from MQTT and keeps them in durable shards.

    Subscriptions (persistent session ``run_binding.writer_client_id``):
    ``topics.shared_samples`` (QoS 1, shared: each sample reaches one writer),
    ``topics.control`` (QoS 1: ``finalize`` and ``announce`` commands), ``topics.acks`` (QoS 0,
    no-local: other writers' acks) and ``topics.status_all`` (QoS 0: every writer's retained
    status, which the finalize round waits on). It publishes acks and its own retained status
    (``ready``, ``sealed``, ``prepared``, ``finalized``, ``stopped``, ``error``; will: ``lost``).
    With ``sample_url`` (a build spreading its samples over several brokers) the samples come
    from that broker instead, on a second connection (:class:`~datagen.writer.links.WriterLinks`).

    Acks: messages are taken in batches of up to ``batch_max`` (also the broker's receive
    window); the batch's new samples are written and made durable (``flush_durable``), then
    each sample's ack is published and only then is its message MQTT-acknowledged
    (``manual_ack``; docs/mqtt-pitfalls.md, pitfall 8). Malformed or foreign-build messages are
    counted, logged and acknowledged without an ack; a control command first commits the
    samples before it.

    Deduplication by key: a sample whose key is durable anywhere in the directory (found at
    start, or learnt from another writer's acks) is acked again but not written again
    (what is kept and how: :class:`~datagen.writer.durable_samples.DurableSamples`).

    ``run()`` returns ``EXIT_OK`` (stopped by ``stop()``, or finalized), ``EXIT_FAILED``,
    ``EXIT_FINALIZE_MISMATCH`` (the finalize round refused: no manifest), ``EXIT_LOCKED``
    (another process runs this writer id on this directory) or ``EXIT_DISK_FULL``.
    """

    def __init__(
        self,
        broker_url: str,
        build_id: str,
        out_dir: str | Path,
        writer_id: str = "0",
        shard_size: int = 1000,
        max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
        session_expiry_s: int = DEFAULT_SESSION_EXPIRY_S,
        batch_max: int = 32,
        ca_file: str | None = None,
        secret: bytes | None = None,
        sample_url: str | None = None,
    ):
        if not valid_writer_id(writer_id):
            raise ValueError(f"invalid writer id {writer_id!r}: use 1-32 of [A-Za-z0-9_-]")
        if session_expiry_s < 1:
            raise ValueError("session_expiry_s must be >= 1 (0 would lose queued samples)")
        self.broker_url = broker_url
        # the broker its samples come from, when the build spreads them over several
        # (datagen.transport.sample_routes); control, acks and status stay on broker_url
        self.sample_url = sample_url if sample_url not in (None, broker_url) else None
        self.build_id = build_id
        self.topics = topics(build_id)
        self.out_dir = Path(out_dir)
        self.writer_id = writer_id
        self.shard_size = shard_size
        self.max_message_bytes = max_message_bytes
        self.session_expiry_s = session_expiry_s
        self.batch_max = batch_max
        self.ca_file = ca_file
        self.secret = secret  # when given, only samples signed with it are accepted
        self.rejected = 0
        self._inbox: queue.Queue[mqtt.MQTTMessage] = queue.Queue()
        self._stop = threading.Event()
        self._sealer = Sealer(secret, self.topics, "writer", writer_id)
        self._opener = Opener(secret, self.topics)  # acks, status and commands must be signed
        self._status = WriterStatus(self.topics, writer_id, self._sealer, self._opener)
        self._binding = WriterBinding(
            secret, self._sealer, self._opener, self._status, hold_max=batch_max // 2
        )
        self._finalized = False

    def stop(self) -> None:
        self._stop.set()

    def run(self) -> int:
        self.out_dir.mkdir(parents=True, exist_ok=True)
        try:
            lock = WriterLock(self.out_dir, self.writer_id)
        except WriterLocked as exc:
            log.error("%s", exc)
            return EXIT_LOCKED
        code = EXIT_FAILED
        try:
            code = self._run()
        except OSError as exc:
            if not is_disk_full(exc):
                raise
            log.error("%s; stopping: what is durable stays", disk_full_message(exc, self.out_dir))
            code = EXIT_DISK_FULL
        finally:
            lock.release(remove=code == EXIT_OK and self._finalized)
        return code

    def _run(self) -> int:
        self._durable = durable = DurableSamples(self.out_dir, self.writer_id, self.shard_size)
        self._links = links = WriterLinks.connect(
            self.broker_url,
            self.sample_url,
            writer_client_id(self.build_id, self.writer_id, self.secret),
            self.topics,
            on_message=self._on_message,
            on_sample=self._inbox.put,
            session_expiry_s=self.session_expiry_s,
            receive_maximum=self.batch_max,
            will=self._status.will(),
            ca_file=self.ca_file,
            on_connected=self._status.reassert,
        )
        self._conn = self._status.conn = links.control
        try:
            changed = durable.changed  # removed by recover(): to be made again
            self._report = (
                {"changed": len(changed), "changed_keys": changed[:10]} if changed else {}
            )
            if self._binding.bound:  # no secret: no run to wait for
                self._announce_durable(None)
                log.info("ready: subscribed to %s", self.topics.shared_samples)
            else:
                self._status.publish(
                    "waiting", samples=len(durable.keys), durable=len(durable.seen)
                )
                log.info("waiting for the coordinator to bind this writer to its run")
            code = self._loop()
            if code is None:  # stopped by a signal
                self._drain()
                durable.close()
                self._status.publish("stopped", samples=len(durable.keys))
                self._links.close(end_session=True)
                log.info("stopped with %d samples on disk; session ended", len(durable.keys))
                return EXIT_OK
            return code
        except Exception as exc:
            if is_disk_full(exc):  # one line, by run(); recovery cuts the open shard
                durable.abandon()
                self._status.publish("error", reason=disk_full_message(exc, self.out_dir))
                self._links.close()
                raise
            log.exception("writer failed")
            durable.close()
            self._status.publish("error", reason=f"{type(exc).__name__}: {exc}")
            self._links.close()
            return EXIT_FAILED

    def _on_message(self, msg: mqtt.MQTTMessage) -> None:
        """paho's thread: statuses are kept (finalize waits on them); the rest queues."""
        if not self._status.receive(msg):
            self._inbox.put(msg)

    def _loop(self) -> int | None:
        while not self._stop.is_set():
            self._status.beat_if_due()
            batch = self._next_batch(0.2)
            if batch:
                code = self._process(batch)
                if code is not None:
                    return code
        return None

    def _next_batch(self, timeout_s: float) -> list[mqtt.MQTTMessage]:
        try:
            batch = [self._inbox.get(timeout=timeout_s)]
        except queue.Empty:
            return []
        while len(batch) < self.batch_max:
            try:
                batch.append(self._inbox.get_nowait())
            except queue.Empty:
                break
        return batch

    def _drain(self) -> None:
        """Stops taking samples and finishes those already delivered (bounded in time)."""
        if not self._links.samples.unsubscribe(self.topics.shared_samples, timeout_s=5):
            log.warning("could not unsubscribe from the samples (broker unreachable?)")
        deadline = time.monotonic() + DRAIN_TIMEOUT_S
        while time.monotonic() < deadline:
            self._status.beat_if_due()
            batch = self._next_batch(DRAIN_QUIET_S)
            if not batch:
                return
            # commands wait for the next writer with this id (if the session outlives us)
            self._process([m for m in batch if m.topic != self.topics.control])
        log.warning("still receiving samples after %.0f s of draining; stopping", DRAIN_TIMEOUT_S)

    def _process(self, batch: list[mqtt.MQTTMessage]) -> int | None:
        pending: list[tuple[mqtt.MQTTMessage, Sample | None]] = []
        for msg in batch:
            if msg.topic == self.topics.control:
                self._commit(pending)
                pending = []
                code = self._control(msg)
                if code is not None:
                    return code
            elif msg.topic == self.topics.acks:
                self._learn_acks(msg)
            elif self._binding.bound:
                pending.append((msg, self._accept(msg)))
            elif not self._binding.hold(msg):
                self._reject(msg, "no run yet: not bound by a coordinator")
                pending.append((msg, None))
        self._commit(pending)
        return None

    def _learn_acks(self, msg: mqtt.MQTTMessage) -> None:
        """Another writer's acks: those samples are durable in the directory already."""
        self._durable.learn(others_acked_keys(self._opener, msg, self.writer_id))

    def _accept(self, msg: mqtt.MQTTMessage) -> Sample | None:
        """Writes a new sample; returns the sample to ack, or None for a rejected message."""
        run = self._binding.run
        try:
            build_id, sample = decode_sample(msg.payload, self.max_message_bytes, self.secret, run)
            if build_id != self.build_id:
                raise WireError(f"build_id {build_id!r} is not this build's {self.build_id!r}")
            if "json" in sample.parts:
                try:
                    meta = loads_bounded(sample.parts["json"], what="part 'json'")
                except ValueError as exc:
                    raise WireError(f"part 'json' is not UTF-8 JSON: {exc}") from None
                if run is not None and (why := run.metadata_mismatch(meta, sample.index)):
                    raise WireError(f"sample {sample.key}: {why}")
        except WireError as exc:
            self._reject(msg, exc)
            return None
        self._durable.keep(sample)
        return sample

    def _reject(self, msg: mqtt.MQTTMessage, why: object) -> None:
        self.rejected += 1
        log.warning("rejected message %d (%d bytes): %s", msg.mid, len(msg.payload), why)

    def _commit(self, pending: list[tuple[mqtt.MQTTMessage, Sample | None]]) -> None:
        if not pending:
            return
        self._durable.flush()
        for msg, sample in pending:
            if sample is not None:
                ack = {"key": sample.key, "index": sample.index, "writer": self.writer_id}
                self._conn.publish(self.topics.acks, self._sealer.seal(self.topics.acks, ack))
            # Published ack packets go out before this PUBACK on the same connection; with a
            # sample broker of its own the PUBACK may come first: a lost ack means the sample
            # is issued again, and reaches this writer set, which holds it (acked, not written).
            self._links.ack(msg)

    def _announce(self, keys: AbstractSet[str]) -> None:
        """Acks every key in ``keys`` again, in batches (``{"indices": [...]}``)."""
        announce(self._conn, self._sealer, self.topics.acks, self.writer_id, keys)

    def _control(self, msg: mqtt.MQTTMessage) -> int | None:
        code = None
        try:
            opened = self._opener.open_any_run(msg.topic, msg.payload)
            # not the coordinator's (unsigned, forged, replayed), or of another run: counted
            run, cmd = opened if opened is not None else ("", {"cmd": None})
            kind = cmd.get("cmd")
            if kind == "bind":
                if self._binding.bind(run, cmd):
                    self._announce_durable(None)
                    held, self._binding.held = self._binding.held, []
                    self._commit([(m, self._accept(m)) for m in held])
            elif opened is None or not self._binding.command_of_our_run(run):
                pass
            elif kind == "finalize":
                code = self._finalize(finalize_args(cmd, self.writer_id))
            elif kind == "announce":
                self._announce_durable(cmd.get("id"))
            else:
                raise ValueError(f"unknown command {cmd!r:.200}")
        except (ValueError, KeyError, TypeError) as exc:
            log.warning("ignoring control message: %s", exc)
        self._links.ack(msg)
        if code is not None:
            self._links.close(end_session=code == EXIT_OK)
        return code

    def _announce_durable(self, announce_id: str | None) -> None:
        """Acks every sample durable in the directory again, then says ``ready`` (with the
        announce command's ``announce_id``)."""
        everything = self._durable.everything()
        self._announce(everything)
        counts = {"samples": len(self._durable.keys), "durable": len(everything), **self._report}
        self._status.publish(
            "ready", **counts, **({"announce": announce_id} if announce_id else {})
        )

    def _finalize(self, args: dict[str, Any] | None) -> int | None:
        if args is None:
            log.info("a finalize for other writers: ignored")
            return None
        deadline = time.monotonic() + args["timeout_s"]
        shards = self._durable.seal()  # nothing more is written
        counters = {
            "rejected_messages": self.rejected,
            "duplicate_messages": self._durable.duplicates,
            # dropped by the opener, or failed in a callback (``MqttConnection.guarded``)
            "rejected_control_messages": sum(self._opener.rejected.values())
            + self._conn.callback_errors,
        }
        done = run_round(
            args,
            deadline,
            out_dir=self.out_dir,
            build_id=self.build_id,
            shards=shards,
            keys=self._durable.keys,
            counters=counters,
            status=self._status,
        )
        if done is None:
            return EXIT_FINALIZE_MISMATCH
        self._durable.shards, self._durable.keys = done
        self._finalized = True
        return EXIT_OK
