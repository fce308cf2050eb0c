"""``datagen writer`` and ``datagen broker``: the long-running services of a build on several
machines (docs/deployment.md)."""

from __future__ import annotations

import argparse
import os

from datagen.cli.common import positive_int


def add_parsers(commands) -> None:
    writer = commands.add_parser(
        "writer",
        help="run a dataset writer for a build on an external broker (e.g. on the storage machine)",
        add_help=False,
    )
    writer.add_argument("args", nargs=argparse.REMAINDER)
    broker = commands.add_parser(
        "broker", help="run Mosquitto with the settings datagen needs and print how to connect"
    )
    broker.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: all)")
    broker.add_argument("--port", type=positive_int, default=1883)
    broker.add_argument("--data-dir", help="persistence directory (default: a temporary one)")
    broker.add_argument("--username", help="default: generated")
    broker.add_argument("--password", help="default: generated; prefer $DATAGEN_BROKER_PASSWORD")
    broker.add_argument("--tls-cert", help="server certificate (PEM): listen with TLS (mqtts://)")
    broker.add_argument("--tls-key", help="the certificate's private key (PEM)")
    broker.add_argument("--advertise-host", help="host name to print in the URL clients use")

    writer.set_defaults(run=run_writer)
    broker.set_defaults(run=run_broker)


def run_writer(args: argparse.Namespace) -> int:
    from datagen.sinks.writer import main as writer_main

    return writer_main(args.args)


def run_broker(args: argparse.Namespace) -> int:
    from datagen.engines.transfer.mosquitto import run_broker_forever

    password = args.password or os.environ.get("DATAGEN_BROKER_PASSWORD")

    def ready(broker) -> None:
        print("datagen: broker ready; connect builds and writers with:", flush=True)
        print(f"  {broker.public_url}", flush=True)
        print("datagen: Ctrl-C stops it.", flush=True)

    return run_broker_forever(
        host=args.host,
        port=args.port,
        data_dir=args.data_dir,
        username=args.username,
        password=password,
        tls_cert=args.tls_cert,
        tls_key=args.tls_key,
        advertise_host=args.advertise_host,
        on_ready=ready,
    )
