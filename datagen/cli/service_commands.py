"""``datagen writer`` and ``datagen broker``: the long-running services of a build on several
machines (docs/deployment.md)."""

from __future__ import annotations

import argparse
import functools
import logging
import os
import signal
import sys
from pathlib import Path

from datagen.cli.common import broker_url, whole_number
from datagen.shards import valid_writer_id
from datagen.transport.broker_url import SAMPLE_BROKER_URL_ENV
from datagen.transport.connection import CA_FILE_ENV, MqttConnectError
from datagen.transport.topics import valid_build_id
from datagen.transport.wire import DEFAULT_MAX_MESSAGE_BYTES, SECRET_ENV, parse_secret
from datagen.writer.dataset_writer import DEFAULT_SESSION_EXPIRY_S, EXIT_FAILED, DatasetWriter

log = logging.getLogger("datagen.writer")  # the writer process's log


def add_parsers(commands) -> None:
    writer = commands.add_parser(
        "writer",
        help="run a dataset writer for a build on an external broker (e.g. on the storage machine)",
        description="The dataset-writer process: MQTT samples in, durable WebDataset shards out.",
    )
    add_writer_options(writer)
    broker = commands.add_parser(
        "broker", help="run Mosquitto with the settings datagen needs and print how to connect"
    )
    broker.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: all)")
    broker.add_argument(
        "--port", type=whole_number(1, 65535), default=1883, help="TCP port (default: 1883)"
    )
    broker.add_argument("--data-dir", help="persistence directory (default: a temporary one)")
    broker.add_argument("--username", help="default: generated")
    broker.add_argument("--password", help="default: generated; prefer $DATAGEN_BROKER_PASSWORD")
    broker.add_argument("--tls-cert", help="server certificate (PEM): listen with TLS (mqtts://)")
    broker.add_argument("--tls-key", help="the certificate's private key (PEM)")
    broker.add_argument("--advertise-host", help="host name to print in the URL clients use")

    writer.set_defaults(run=functools.partial(run_writer_command, writer))
    broker.set_defaults(run=run_broker)


def add_writer_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--broker",
        default=os.environ.get("DATAGEN_BROKER_URL"),
        help="mqtt://user:pass@host:port or mqtts://... (default: $DATAGEN_BROKER_URL, "
        "which keeps the password off the process list)",
    )
    p.add_argument(
        "--sample-broker",
        metavar="URL",
        type=broker_url,
        default=os.environ.get(SAMPLE_BROKER_URL_ENV),
        help="take the samples from this broker, one of a build's --sample-broker list; "
        f"commands, acks and status stay on --broker (default: ${SAMPLE_BROKER_URL_ENV}, "
        "else --broker; docs/scale-out.md, 'Several brokers')",
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


def run_writer_command(p: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """Checks the options (errors through ``p``), reads the build's secret from ``$SECRET_ENV``
    (hex) and runs the writer."""
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
    return run_writer(
        args.out,
        args.build_id,
        args.writer_id,
        broker_url=args.broker,
        sample_url=args.sample_broker,
        shard_size=args.shard_size,
        max_message_bytes=args.max_message_bytes,
        session_expiry_s=args.session_expiry,
        ca_file=args.ca_file,
        secret=secret,
        log_level=args.log_level,
    )


def run_broker(args: argparse.Namespace) -> int:
    from datagen.transport.broker_service import run_broker_forever
    from datagen.transport.broker_settings import service_settings

    password = args.password or os.environ.get("DATAGEN_BROKER_PASSWORD")

    def ready(broker) -> None:
        print("datagen: broker ready; connect builds and writers with:", flush=True)
        print(f"  {broker.public_url}", flush=True)
        print("datagen: Ctrl-C stops it.", flush=True)

    settings = service_settings(
        host=args.host,
        port=args.port,
        data_dir=args.data_dir,
        username=args.username,
        password=password,
        tls_cert=args.tls_cert,
        tls_key=args.tls_key,
        advertise_host=args.advertise_host,
    )
    return run_broker_forever(settings, on_ready=ready)


def run_writer(
    out: str | Path,
    build_id: str,
    writer_id: str = "0",
    *,
    broker_url: str,
    sample_url: str | None = None,
    shard_size: int = 1000,
    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
    session_expiry_s: int = DEFAULT_SESSION_EXPIRY_S,
    ca_file: str | None = None,
    secret: bytes | None = None,
    log_level: str = "INFO",
) -> int:
    """Runs one writer until SIGTERM/SIGINT or a finished build; returns its exit code. Logs go
    to stderr at ``log_level``, each line tagged ``writer[{writer_id}]``."""
    logging.basicConfig(
        stream=sys.stderr,
        level=log_level.upper(),
        format=f"%(asctime)s writer[{writer_id}] %(levelname)s %(name)s: %(message)s",
        force=True,
    )
    writer = DatasetWriter(
        broker_url,
        build_id,
        out,
        writer_id=writer_id,
        sample_url=sample_url,
        shard_size=shard_size,
        max_message_bytes=max_message_bytes,
        session_expiry_s=session_expiry_s,
        ca_file=ca_file,
        secret=secret,
    )
    if secret is None:
        log.warning("no $%s: accepting any well-formed sample of build %s", SECRET_ENV, build_id)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: writer.stop())
    try:
        return writer.run()
    except (MqttConnectError, ValueError) as exc:
        log.error("%s", exc)
        return EXIT_FAILED
