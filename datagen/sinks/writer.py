"""The dataset-writer process: MQTT samples in, durable WebDataset shards out.

``python -m datagen.sinks.writer --broker URL --build-id ID --out DIR [--writer-id W]``

Per message: decode (malformed or foreign-build messages are counted, logged and dropped),
skip keys already on disk, write, fsync, publish an ack on the acks topic, and only then
MQTT-acknowledge the message (``manual_ack``, pitfall 8). The session is persistent (fixed
client id, clean_start=False, session expiry > 0, pitfall 5), so messages sent while the
writer is down wait at the broker. A ``finalize`` control message writes ``manifest.json``.
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
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt

from datagen.engines.mqtt_client import MqttConnectError, MqttConnection
from datagen.engines.transfer import topics, valid_build_id
from datagen.engines.wire import DEFAULT_MAX_MESSAGE_BYTES, WireError, decode_sample
from datagen.sample import Sample
from datagen.sinks.webdataset import (
    ShardInfo,
    ShardWriter,
    journal_path,
    keys_sha256,
    recover,
    valid_writer_id,
    write_manifest,
)

log = logging.getLogger("datagen.writer")

EXIT_OK = 0
EXIT_FINALIZE_MISMATCH = 3
EXIT_FAILED = 1


class DatasetWriter:
    def __init__(
        self,
        broker_url: str,
        build_id: str,
        out_dir: str | Path,
        writer_id: str = "0",
        shard_size: int = 1000,
        max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
        session_expiry_s: int = 7 * 24 * 3600,
        batch_max: int = 32,
    ):
        self.broker_url = broker_url
        self.build_id = build_id
        self.topics = topics(build_id)
        self.out_dir = Path(out_dir)
        self.writer_id = writer_id
        self.shard_size = shard_size
        self.max_message_bytes = max_message_bytes
        self.session_expiry_s = session_expiry_s
        self.batch_max = batch_max
        self.rejected = 0
        self.duplicates = 0
        self._inbox: queue.Queue[mqtt.MQTTMessage] = queue.Queue()
        self._stop = threading.Event()

    def stop(self) -> None:
        self._stop.set()

    def run(self) -> int:
        self.out_dir.mkdir(parents=True, exist_ok=True)
        recovered = recover(self.out_dir, self.writer_id)
        self._old_shards: list[ShardInfo] = recovered.shards
        self._keys = set(recovered.keys)
        self._seen = recovered.keys | recovered.other_keys
        if self._keys:
            log.info(
                "resuming: %d samples already in %d shards", len(self._keys), len(self._old_shards)
            )
        self._sink = ShardWriter(
            self.out_dir, self.writer_id, self.shard_size, recovered.next_shard
        )
        lost = {"state": "lost", "writer": self.writer_id}
        self._conn = MqttConnection(
            self.broker_url,
            f"datagen-{self.build_id}-writer-{self.writer_id}",
            subscriptions=[(self.topics.samples, 1), (self.topics.control, 1)],
            on_message=self._inbox.put,
            manual_ack=True,
            session_expiry_s=self.session_expiry_s,
            receive_maximum=self.batch_max,
            will=(self.topics.status, json.dumps(lost).encode(), 1, True),
        )
        try:
            self._status("ready", samples=len(self._keys))
            log.info("ready: subscribed to %s", self.topics.samples)
            code = self._loop()
        except Exception as exc:
            log.exception("writer failed")
            self._sink.close()
            self._status("error", reason=f"{type(exc).__name__}: {exc}")
            self._conn.close()
            return EXIT_FAILED
        if code is None:  # stopped by a signal: keep the session, messages wait for us
            self._sink.close()
            self._status("stopped", samples=len(self._keys))
            self._conn.close()
            log.info("stopped with %d samples on disk", len(self._keys))
            return EXIT_OK
        return code

    def _loop(self) -> int | None:
        while not self._stop.is_set():
            try:
                batch = [self._inbox.get(timeout=0.2)]
            except queue.Empty:
                continue
            while len(batch) < self.batch_max:
                try:
                    batch.append(self._inbox.get_nowait())
                except queue.Empty:
                    break
            code = self._process(batch)
            if code is not None:
                return code
        return None

    def _process(self, batch: list[mqtt.MQTTMessage]) -> int | None:
        pending: list[tuple[mqtt.MQTTMessage, Sample | None]] = []
        for msg in batch:
            if msg.topic == self.topics.control:
                self._commit(pending)
                pending = []
                code = self._control(msg)
                if code is not None:
                    return code
                continue
            pending.append((msg, self._accept(msg)))
        self._commit(pending)
        return None

    def _accept(self, msg: mqtt.MQTTMessage) -> Sample | None:
        """Writes a new sample; returns the sample to ack, or None for a rejected message."""
        try:
            build_id, sample = decode_sample(msg.payload, self.max_message_bytes)
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

    def _control(self, msg: mqtt.MQTTMessage) -> int | None:
        try:
            cmd = json.loads(msg.payload)
            if not isinstance(cmd, dict) or cmd.get("cmd") != "finalize":
                raise ValueError(f"unknown command {cmd!r}")
            expected, manifest = cmd["expected"], cmd.get("manifest", {})
            if not isinstance(expected, int) or not isinstance(manifest, dict):
                raise ValueError("finalize needs an integer 'expected' and an object 'manifest'")
        except (ValueError, KeyError) as exc:
            log.warning("ignoring control message: %s", exc)
            self._conn.client.ack(msg.mid, msg.qos)
            return None
        code = self._finalize(expected, manifest)
        self._conn.client.ack(msg.mid, msg.qos)
        self._conn.close(end_session=code == EXIT_OK)
        return code

    def _finalize(self, expected: int, manifest: dict[str, Any]) -> int:
        shards = self._old_shards + self._sink.close()
        count = sum(s.samples for s in shards)
        if count != expected:
            reason = f"expected {expected} samples, have {count}"
            log.error("finalize refused: %s", reason)
            self._status("error", reason=reason, samples=count, expected=expected)
            return EXIT_FINALIZE_MISMATCH
        doc = {
            **manifest,
            "build_id": self.build_id,
            "writer": self.writer_id,
            "format": "webdataset",
            "samples": count,
            "shards": [s.to_json() for s in shards],
            "rejected_messages": self.rejected,
            "duplicate_messages": self.duplicates,
            "keys_sha256": keys_sha256(self._keys),
        }
        write_manifest(self.out_dir, doc)
        journal_path(self.out_dir, self.writer_id).unlink(missing_ok=True)
        self._status("finalized", samples=count)
        log.info("finalized: %d samples in %d shards", count, len(shards))
        return EXIT_OK

    def _status(self, state: str, **fields: Any) -> None:
        msg = {"state": state, "writer": self.writer_id, **fields}
        try:
            info = self._conn.publish_json(self.topics.status, msg, qos=1, retain=True)
            info.wait_for_publish(10)
        except (RuntimeError, ValueError) as exc:
            log.warning("could not publish status %r: %s", state, exc)


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
    p.add_argument("--log-level", default="INFO")
    args = p.parse_args(argv)
    if not valid_build_id(args.build_id):
        p.error(f"invalid --build-id {args.build_id!r}: use 1-64 of [A-Za-z0-9_.-]")
    if not valid_writer_id(args.writer_id):
        p.error(f"invalid --writer-id {args.writer_id!r}: use 1-32 of [A-Za-z0-9_-]")
    if not args.broker:
        p.error("--broker URL (or $DATAGEN_BROKER_URL) is required")
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
    )
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: writer.stop())
    try:
        return writer.run()
    except MqttConnectError as exc:
        log.error("%s", exc)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
