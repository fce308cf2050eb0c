"""``datagen monitor``: serve the live monitor page (docs/monitor.md); and the page a
``datagen build --monitor`` starts for its own broker."""

from __future__ import annotations

import argparse
import contextlib
import os
import socket
import time
from collections.abc import Sequence

from datagen.cli.common import build_id, whole_number
from datagen.errors import UserInputError
from datagen.monitor.server import MonitorServer, PageConfig, page_config

MONITOR_URL_ENV = "DATAGEN_MONITOR_BROKER_URL"
INTERRUPT_POLL_S = 1.0  # seconds: the longest Ctrl-C may wait to be seen


def add_parsers(commands) -> None:
    monitor = commands.add_parser(
        "monitor",
        help="serve a page that shows builds live in the browser (MQTT over WebSockets)",
        description="Serve the live build monitor: the page connects to the broker's WebSockets "
        "listener itself and shows progress, rate, ETA, workers, faults, previews and success "
        "rates of the builds on that broker.",
    )
    monitor.add_argument(
        "--broker",
        default=os.environ.get(MONITOR_URL_ENV),
        help="the broker's WebSockets listener, ws://[user:pass@]host:port or wss://... "
        f"(default: ${MONITOR_URL_ENV}; none: the page asks); use a read-only monitor user",
    )
    monitor.add_argument("--build-id", type=build_id, help="the build to show (default: choose)")
    monitor.add_argument("--host", default="127.0.0.1", help="address the page is served on")
    monitor.add_argument(
        "--public-name",
        action="append",
        default=[],
        metavar="NAME",
        help="a name browsers use for this machine besides its IP addresses, localhost and its "
        "host name (e.g. a DNS alias); requests naming any other host are refused",
    )
    monitor.add_argument(
        "--port", type=whole_number(0, 65535), default=8765, help="0: a free port (default 8765)"
    )
    monitor.set_defaults(run=run_monitor)


def run_monitor(args: argparse.Namespace) -> int:
    try:
        config = page_config(args.broker, args.build_id)
    except ValueError as exc:
        raise UserInputError(str(exc)) from None
    with (
        serving(config, args.host, args.port, args.public_name) as server,
        contextlib.suppress(KeyboardInterrupt),
    ):
        where = f" for {config.broker}" if config.broker else ""
        print(f"datagen: monitor{where}: open {server.url}  (Ctrl-C stops it)", flush=True)
        # Timed sleeps, not one untimed wait: the kernel may deliver SIGINT to a server
        # thread, and the main thread, which runs Python's handler, sees it only when it wakes.
        while True:
            time.sleep(INTERRUPT_POLL_S)
    return 0


@contextlib.contextmanager
def serving(
    config: PageConfig, host: str = "127.0.0.1", port: int = 0, public_names: Sequence[str] = ()
):
    try:
        server = MonitorServer(config, host, port, public_names)
    except socket.gaierror as exc:
        raise UserInputError(
            f"--host {host}: not an address of this machine ({exc.strerror})"
        ) from None
    except OSError as exc:
        raise UserInputError(
            f"--port {port}: cannot serve the monitor page on {host}:{port} ({exc.strerror}); "
            f"choose another port, or --port 0 for a free one"
        ) from None
    with server:
        yield server


def build_monitor(stack: contextlib.ExitStack):
    """For ``datagen build --monitor``: a callback given the build's own broker (with its
    WebSockets listener) that serves the page for it on a free port and prints the URL."""

    def start(broker) -> None:
        config = PageConfig(
            broker.websockets_url, broker.monitor_username, broker.monitor_password or ""
        )
        server = stack.enter_context(serving(config))
        print(f"datagen: watch the build live: open {server.url}", flush=True)

    return start
