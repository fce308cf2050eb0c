"""The dataset-writer process: MQTT samples in, durable WebDataset shards out.

``python -m datagen.sinks.writer --broker URL --build-id ID --out DIR [--writer-id W]``
(also ``datagen writer ...``). Several writers may serve one build, into one directory (same
machine or a shared file system), each with its own ``--writer-id``: they share the samples
through an MQTT v5 shared subscription, so each sample reaches one of them.

Per message: decode (malformed or foreign-build messages are counted, logged and dropped),
skip keys already durable in the directory or acknowledged by another writer, write, fsync,
publish an ack, and only then MQTT-acknowledge the message (``manual_ack``, pitfall 8).

Sessions: persistent (fixed client id, clean_start=False) with a bounded expiry
(``--session-expiry``, default 60 s): a writer restarted within it gets the samples the broker
held for it; one that never returns stops swallowing its share of the samples when the broker
expires its session (pitfall 3), and the coordinator re-issues what was held. A clean stop
(SIGTERM/SIGINT, or a finished build) unsubscribes, finishes what was delivered and ends the
session, so nothing more is routed to it.

On start a writer repairs its shards, then acks every sample durable in the directory (all
writers' shards, in batches) before announcing ``ready``. ``finalize``: see
``datagen/sinks/finalize.py`` and docs/wire-format.md.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import queue
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt
from paho.mqtt.subscribeoptions import SubscribeOptions

from datagen.engines.transfer.collector import ack_indices, topics, valid_build_id
from datagen.engines.transfer.connection import CA_FILE_ENV, MqttConnectError, MqttConnection
from datagen.engines.transfer.wire import (
    DEFAULT_MAX_MESSAGE_BYTES,
    SECRET_ENV,
    WireError,
    decode_sample,
    parse_secret,
)
from datagen.sample import Sample, sample_key
from datagen.shards import (
    ShardInfo,
    ShardWriter,
    WriterLock,
    WriterLocked,
    durable_keys,
    journal_path,
    recover,
    shards_by_writer,
    valid_writer_id,
    write_manifest,
)
from datagen.sinks.finalize import (
    FinalizeError,
    combine,
    drop_copies_held_by_smaller,
    part_path,
    write_part,
)

log = logging.getLogger("datagen.writer")

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_FINALIZE_MISMATCH = 3  # finalize refused (count mismatch, a writer missing): no manifest
EXIT_LOCKED = 4  # another process runs this writer id on this directory

DEFAULT_SESSION_EXPIRY_S = 60
DEFAULT_FINALIZE_TIMEOUT_S = 300.0
ANNOUNCE_BATCH = 10_000  # indices per batched ack: ~80 KB, far below any broker's packet limit
DRAIN_TIMEOUT_S = 10.0
DRAIN_QUIET_S = 0.5


class DatasetWriter:
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
    ):
        if not valid_writer_id(writer_id):
            raise ValueError(f"invalid writer id {writer_id!r}: use 1-32 of [A-Za-z0-9_-]")
        if session_expiry_s < 1:
            raise ValueError("session_expiry_s must be >= 1 (0 would lose queued samples)")
        self.broker_url = broker_url
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
        self.duplicates = 0
        self._inbox: queue.Queue[mqtt.MQTTMessage] = queue.Queue()
        self._stop = threading.Event()
        self._peers: dict[str, dict[str, Any]] = {}  # latest status of every writer
        self._peers_cond = threading.Condition()
        self._last_status: dict[str, Any] | None = None
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
        finally:
            lock.release(remove=code == EXIT_OK and self._finalized)
        return code

    def _run(self) -> int:
        recovered = recover(self.out_dir, self.writer_id)
        self._shards: list[ShardInfo] = recovered.shards
        self._keys = set(recovered.keys)  # in this writer's shards
        self._seen = recovered.keys | recovered.other_keys  # durable anywhere in the directory
        if self._seen:
            log.info(
                "resuming: %d samples in my %d shards, %d in the directory",
                len(self._keys),
                len(self._shards),
                len(self._seen),
            )
        lost = {"state": "lost", "writer": self.writer_id}
        self._conn = MqttConnection(
            self.broker_url,
            f"datagen-{self.build_id}-writer-{self.writer_id}",
            subscriptions=[
                (self.topics.shared_samples, 1),
                (self.topics.control, 1),
                # QoS 0: never held back by the receive window full of samples, never queued
                (self.topics.acks, SubscribeOptions(qos=0, noLocal=True)),
                (self.topics.status_all, SubscribeOptions(qos=0)),
            ],
            on_message=self._on_message,
            manual_ack=True,
            session_expiry_s=self.session_expiry_s,
            receive_maximum=self.batch_max,
            will=(self.topics.status(self.writer_id), json.dumps(lost).encode(), 1, True),
            ca_file=self.ca_file,
            on_connected=self._reassert_status,
        )
        self._sink = ShardWriter(
            self.out_dir, self.writer_id, self.shard_size, recovered.next_shard
        )
        try:
            self._announce(self._seen)
            self._status("ready", samples=len(self._keys), durable=len(self._seen))
            log.info("ready: subscribed to %s", self.topics.shared_samples)
            code = self._loop()
            if code is None:  # stopped by a signal
                self._drain()
                self._sink.close()
                self._status("stopped", samples=len(self._keys))
                self._conn.close(end_session=True)
                log.info("stopped with %d samples on disk; session ended", len(self._keys))
                return EXIT_OK
            return code
        except Exception as exc:
            log.exception("writer failed")
            self._sink.close()
            self._status("error", reason=f"{type(exc).__name__}: {exc}")
            self._conn.close()
            return EXIT_FAILED

    def _on_message(self, msg: mqtt.MQTTMessage) -> None:
        """paho's thread: statuses are kept here (finalize waits on them); the rest queues."""
        if msg.topic.startswith(self.topics.status_prefix):
            try:
                status = json.loads(msg.payload) if msg.payload else None
            except ValueError:
                status = None
            if isinstance(status, dict):
                with self._peers_cond:
                    self._peers[msg.topic[len(self.topics.status_prefix) :]] = status
                    self._peers_cond.notify_all()
            return
        self._inbox.put(msg)

    def _loop(self) -> int | None:
        while not self._stop.is_set():
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
        if not self._conn.unsubscribe(self.topics.shared_samples, timeout_s=5):
            log.warning("could not unsubscribe from the samples (broker unreachable?)")
        deadline = time.monotonic() + DRAIN_TIMEOUT_S
        while time.monotonic() < deadline:
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
            else:
                pending.append((msg, self._accept(msg)))
        self._commit(pending)
        return None

    def _learn_acks(self, msg: mqtt.MQTTMessage) -> None:
        """Another writer's acks: those samples are durable in the directory already."""
        try:
            obj = json.loads(msg.payload)
        except ValueError:
            return
        indices = ack_indices(obj)
        if indices is not None and obj.get("writer") != self.writer_id:
            self._seen.update(sample_key(i) for i in indices)

    def _accept(self, msg: mqtt.MQTTMessage) -> Sample | None:
        """Writes a new sample; returns the sample to ack, or None for a rejected message."""
        try:
            build_id, sample = decode_sample(msg.payload, self.max_message_bytes, self.secret)
            if build_id != self.build_id:
                raise WireError(f"build_id {build_id!r} is not this build's {self.build_id!r}")
            if "json" in sample.parts:
                try:
                    json.loads(sample.parts["json"].decode("utf-8"))
                except (UnicodeDecodeError, ValueError) as exc:
                    raise WireError(f"part 'json' is not UTF-8 JSON: {exc}") from None
        except WireError as exc:
            self.rejected += 1
            log.warning("rejected message %d (%d bytes): %s", msg.mid, len(msg.payload), exc)
            return None
        if sample.key in self._seen:
            self.duplicates += 1
            log.debug("duplicate %s: acking again, not rewriting", sample.key)
            return sample
        self._sink.write(sample)
        self._seen.add(sample.key)
        self._keys.add(sample.key)
        return sample

    def _commit(self, pending: list[tuple[mqtt.MQTTMessage, Sample | None]]) -> None:
        if not pending:
            return
        self._sink.flush_durable()
        for msg, sample in pending:
            if sample is not None:
                ack = {"key": sample.key, "index": sample.index, "writer": self.writer_id}
                self._conn.publish_json(self.topics.acks, ack, qos=1)
            # Published ack packets go out before this PUBACK on the same connection.
            self._conn.client.ack(msg.mid, msg.qos)

    def _announce(self, keys: set[str]) -> None:
        """Acks every key in ``keys`` again, in batches (``{"indices": [...]}``)."""
        indices = sorted(int(k) for k in keys)
        for start in range(0, len(indices), ANNOUNCE_BATCH):
            chunk = indices[start : start + ANNOUNCE_BATCH]
            self._conn.publish_json(
                self.topics.acks, {"indices": chunk, "writer": self.writer_id}, qos=1
            )
        if indices:
            log.info("announced %d durable samples", len(indices))

    def _control(self, msg: mqtt.MQTTMessage) -> int | None:
        code = None
        try:
            cmd = json.loads(msg.payload)
            kind = cmd.get("cmd") if isinstance(cmd, dict) else None
            if kind == "finalize":
                code = self._finalize(_finalize_args(cmd, self.writer_id))
            elif kind == "announce":
                everything = set(self._keys)
                for other, paths in shards_by_writer(self.out_dir).items():
                    if other != self.writer_id:
                        everything |= durable_keys(self.out_dir, other, paths)
                self._seen |= everything
                self._announce(everything)
                self._status(
                    "ready",
                    samples=len(self._keys),
                    durable=len(everything),
                    announce=cmd.get("id"),
                )
            else:
                raise ValueError(f"unknown command {cmd!r:.200}")
        except (ValueError, KeyError, TypeError) as exc:
            log.warning("ignoring control message: %s", exc)
        self._conn.client.ack(msg.mid, msg.qos)
        if code is not None:
            self._conn.close(end_session=code == EXIT_OK)
        return code

    # --- finalize ----------------------------------------------------------------------------
    def _finalize(self, args: dict[str, Any] | None) -> int | None:
        if args is None:
            log.info("a finalize for other writers: ignored")
            return None
        round_id, writers = args["id"], args["writers"]
        leader = writers[0]
        deadline = time.monotonic() + args["timeout_s"]
        self._shards += self._sink.close()  # sealed: nothing more is written
        self._status("sealed", round=round_id, samples=len(self._keys))
        try:
            self._wait_peers(writers, round_id, {"sealed", "prepared", "finalized"}, deadline)
            self._shards, removed = drop_copies_held_by_smaller(
                self.out_dir, self.writer_id, self._shards
            )
            self._keys -= removed
            write_part(
                self.out_dir,
                self.writer_id,
                round_id,
                build_id=self.build_id,
                samples=len(self._keys),
                shards=[s.to_json() for s in self._shards],
                rejected_messages=self.rejected,
                duplicate_messages=self.duplicates,
                copies_removed=len(removed),
            )
            self._status("prepared", round=round_id, samples=len(self._keys))
            if self.writer_id == leader:
                self._wait_peers(writers, round_id, {"prepared", "finalized"}, deadline)
                doc = combine(self.out_dir, writers, round_id, args["expected"])
                manifest = {**args["manifest"], "build_id": self.build_id, "format": "webdataset"}
                write_manifest(self.out_dir, {**manifest, **doc})
                total = doc["samples"]
            else:
                total = self._wait_peers([leader], round_id, {"finalized"}, deadline)[leader][
                    "samples"
                ]
        except FinalizeError as exc:
            log.error("finalize refused: %s", exc.reason)
            self._status("error", round=round_id, reason=exc.reason, **exc.fields)
            return EXIT_FINALIZE_MISMATCH
        journal_path(self.out_dir, self.writer_id).unlink(missing_ok=True)
        part_path(self.out_dir, self.writer_id).unlink(missing_ok=True)
        self._finalized = True
        self._status("finalized", round=round_id, samples=total, own=len(self._keys))
        log.info(
            "finalized: %d samples (%d in my %d shards)", total, len(self._keys), len(self._shards)
        )
        return EXIT_OK

    def _wait_peers(
        self, writers: list[str], round_id: str, states: set[str], deadline: float
    ) -> dict[str, dict[str, Any]]:
        """Waits until every writer's latest status of this round is in ``states``."""

        def reached(w: str) -> bool:
            msg = self._peers.get(w, {})
            return msg.get("round") == round_id and msg.get("state") in states

        with self._peers_cond:
            while True:
                for w in writers:
                    msg = self._peers.get(w, {})
                    if (
                        msg.get("round") == round_id
                        and msg.get("state") == "error"
                        and w != self.writer_id
                    ):
                        raise FinalizeError(f"writer {w!r}: {msg.get('reason')}")
                missing = [w for w in writers if not reached(w)]
                if not missing:
                    return {w: self._peers[w] for w in writers}
                left = deadline - time.monotonic()
                if left <= 0:
                    raise FinalizeError(
                        f"writers {missing} did not reach {'/'.join(sorted(states))} in time; "
                        "is every listed writer running?"
                    )
                self._peers_cond.wait(min(left, 1.0))

    def _reassert_status(self) -> None:
        """After a reconnect: the broker may have published our will (``lost``) meanwhile, as
        Mosquitto does for every client when it shuts down."""
        msg = self._last_status
        if msg is not None:
            self._conn.publish_json(self.topics.status(self.writer_id), msg, qos=1, retain=True)

    def _status(self, state: str, **fields: Any) -> None:
        msg = {"state": state, "writer": self.writer_id, **fields}
        self._last_status = msg
        try:
            info = self._conn.publish_json(
                self.topics.status(self.writer_id), msg, qos=1, retain=True
            )
            info.wait_for_publish(10)
        except (RuntimeError, ValueError) as exc:
            log.warning("could not publish status %r: %s", state, exc)


def _finalize_args(cmd: dict[str, Any], writer_id: str) -> dict[str, Any] | None:
    """The checked arguments of a finalize command; None if this writer is not listed."""
    writers = cmd.get("writers", [writer_id])
    if (
        not isinstance(writers, list)
        or not writers
        or not all(isinstance(w, str) and valid_writer_id(w) for w in writers)
    ):
        raise ValueError(f"finalize 'writers' must be a list of writer ids, got {writers!r:.200}")
    expected, manifest = cmd.get("expected"), cmd.get("manifest", {})
    if (
        not isinstance(expected, int)
        or isinstance(expected, bool)
        or not isinstance(manifest, dict)
    ):
        raise ValueError("finalize needs an integer 'expected' and an object 'manifest'")
    timeout_s = cmd.get("timeout_s", DEFAULT_FINALIZE_TIMEOUT_S)
    if not isinstance(timeout_s, int | float) or timeout_s <= 0:
        raise ValueError(f"finalize 'timeout_s' must be a positive number, got {timeout_s!r}")
    if writer_id not in writers:
        return None
    return {
        "id": str(cmd.get("id", "")),
        "writers": sorted(set(writers)),
        "expected": expected,
        "manifest": manifest,
        "timeout_s": float(timeout_s),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m datagen.sinks.writer", description=__doc__.split("\n")[0]
    )
    p.add_argument(
        "--broker",
        default=os.environ.get("DATAGEN_BROKER_URL"),
        help="mqtt://user:pass@host:port or mqtts://... (default: $DATAGEN_BROKER_URL, "
        "which keeps the password off the process list)",
    )
    p.add_argument("--build-id", required=True)
    p.add_argument("--out", required=True, help="dataset directory")
    p.add_argument("--writer-id", default="0")
    p.add_argument("--shard-size", type=int, default=1000, help="samples per shard")
    p.add_argument("--max-message-bytes", type=int, default=DEFAULT_MAX_MESSAGE_BYTES)
    p.add_argument(
        "--ca-file",
        help=f"CA certificate that signed an mqtts:// broker's certificate (default: ${CA_FILE_ENV}, "
        "else the system trust store)",
    )
    p.add_argument(
        "--session-expiry",
        type=int,
        default=DEFAULT_SESSION_EXPIRY_S,
        metavar="S",
        help="seconds the broker keeps holding this writer's samples after it vanished "
        f"(default {DEFAULT_SESSION_EXPIRY_S}; see docs/deployment.md)",
    )
    p.add_argument("--log-level", default="INFO")
    args = p.parse_args(argv)
    if not valid_build_id(args.build_id):
        p.error(f"invalid --build-id {args.build_id!r}: use 1-64 of [A-Za-z0-9_.-]")
    if not valid_writer_id(args.writer_id):
        p.error(f"invalid --writer-id {args.writer_id!r}: use 1-32 of [A-Za-z0-9_-]")
    if not args.broker:
        p.error("--broker URL (or $DATAGEN_BROKER_URL) is required")
    if args.session_expiry < 1:
        p.error("--session-expiry must be >= 1 second")
    secret = None
    if os.environ.get(SECRET_ENV):
        try:
            secret = parse_secret(os.environ[SECRET_ENV])
        except ValueError as exc:
            p.error(str(exc))
    logging.basicConfig(
        stream=sys.stderr,
        level=args.log_level.upper(),
        format=f"%(asctime)s writer[{args.writer_id}] %(levelname)s %(name)s: %(message)s",
    )
    writer = DatasetWriter(
        args.broker,
        args.build_id,
        args.out,
        writer_id=args.writer_id,
        shard_size=args.shard_size,
        max_message_bytes=args.max_message_bytes,
        session_expiry_s=args.session_expiry,
        ca_file=args.ca_file,
        secret=secret,
    )
    if secret is None:
        log.warning(
            "no $%s: accepting any well-formed sample of build %s", SECRET_ENV, args.build_id
        )
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: writer.stop())
    try:
        return writer.run()
    except (MqttConnectError, ValueError) as exc:
        log.error("%s", exc)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
