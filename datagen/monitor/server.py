"""The monitor page's web server: the static page of this package (``static/``) and one
generated ``config.json`` (which broker to connect to, as whom, and which build), on
127.0.0.1 by default, to requests that pass ``request_checks``, over connections bounded in
number, threads and time (``connections``). The page itself talks to the broker over
MQTT-over-WebSockets (docs/monitor.md); this server never touches MQTT.
"""

from __future__ import annotations

import io
import json
import logging
import socket
import threading
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from http.server import BaseHTTPRequestHandler
from importlib.resources import files
from pathlib import Path
from urllib.parse import unquote, urlsplit

from datagen.monitor.connections import Connections
from datagen.monitor.request_checks import (
    WILDCARD_HOSTS,
    RefusedRequest,
    check_host,
    check_own_fetch,
    requested_path,
    server_names,
)
from datagen.transport.broker_url import redact

log = logging.getLogger(__name__)
STATIC = Path(str(files("datagen.monitor") / "static"))
WEBSOCKET_SCHEMES = ("ws", "wss")


@dataclass(frozen=True)
class PageConfig:
    """What ``config.json`` tells the page: broker URL (``ws://host:port[/path]``, no
    credentials), the monitor account, and the build to show ("" = let the user choose)."""

    broker: str = ""
    username: str = ""
    password: str = ""
    build_id: str = ""


def page_config(broker_url: str | None, build_id: str | None) -> PageConfig:
    """``ws[s]://[user:pass@]host:port[/path]`` -> a PageConfig; raises ValueError saying what
    is wrong with the URL."""
    if not broker_url:
        return PageConfig(build_id=build_id or "")
    parts = urlsplit(broker_url)
    if parts.scheme not in WEBSOCKET_SCHEMES:
        raise ValueError(
            f"--broker {redact(broker_url)}: expected a WebSockets URL, ws://host:port or "
            f"wss://host:port (the broker's websockets listener, not its mqtt:// port)"
        )
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None:
        raise ValueError(f"--broker {redact(broker_url)}: expected ws[s]://host:port")
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    url = f"{parts.scheme}://{host}:{port}{parts.path}"
    return PageConfig(
        url, unquote(parts.username or ""), unquote(parts.password or ""), build_id or ""
    )


CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".md": "text/plain; charset=utf-8",
}


def static_files() -> dict[str, Path]:
    """The only paths served besides ``/config.json``: ``/`` and each file of ``static/``."""
    found = {"/" + p.relative_to(STATIC).as_posix(): p for p in STATIC.rglob("*") if p.is_file()}
    return found | {"/": STATIC / "index.html"}


def content_security_policy(config: PageConfig) -> str:
    """The page may load its own files and open a WebSocket to its broker only (any, when no
    broker is configured and the page asks for one)."""
    if config.broker:
        parts = urlsplit(config.broker)
        broker = f"{parts.scheme}://{parts.netloc}"
    else:
        broker = "ws: wss:"
    return (
        f"default-src 'self'; connect-src 'self' {broker}; img-src 'self' blob:; worker-src blob:; "
        "object-src 'none'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
    )


class _Handler(BaseHTTPRequestHandler):
    """Answers the one request whose head (request line and headers) ``connections`` read."""

    site: _Site

    def __init__(self, head: bytes, site: _Site, connection: socket.socket, address: tuple):
        self.head, self.site = head, site
        super().__init__(connection, address, None)  # type: ignore[arg-type]

    def setup(self) -> None:
        super().setup()
        self.rfile = io.BytesIO(self.head)

    def do_GET(self) -> None:
        self._answer(with_body=True)

    def do_HEAD(self) -> None:
        self._answer(with_body=False)

    def _answer(self, with_body: bool) -> None:
        try:
            check_host(self.headers.get_all("Host") or [], self.site.names)
            path = requested_path(self.path)
            if path == "/config.json":
                check_own_fetch(self.headers.get("Sec-Fetch-Site"))
                body = json.dumps(asdict(self.site.page_config)).encode("utf-8")
                self._send(200, "application/json", body, with_body, {"Cache-Control": "no-store"})
                return
            file = self.site.files.get(path)
            if file is None:
                raise RefusedRequest(404, "no such file")
        except RefusedRequest as refused:
            body = f"{refused.status} {refused.reason}\n".encode()
            self._send(refused.status, "text/plain; charset=utf-8", body, with_body)
            return
        extra = {"Content-Security-Policy": self.site.policy} if file.suffix == ".html" else {}
        content_type = CONTENT_TYPES.get(file.suffix, "application/octet-stream")
        self._send(200, content_type, file.read_bytes(), with_body, extra)

    def _send(
        self,
        status: int,
        content_type: str,
        body: bytes,
        with_body: bool,
        headers: dict | None = None,
    ) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("X-Content-Type-Options", "nosniff")
        for name, value in (headers or {}).items():
            self.send_header(name, value)
        self.end_headers()
        if with_body:
            self.wfile.write(body)

    def log_message(self, format: str, *args) -> None:  # quiet: the terminal is the build's
        pass


@dataclass(frozen=True)
class _Site:
    """What the server answers with: the page's config, its policy, its files and names."""

    page_config: PageConfig
    policy: str
    files: dict[str, Path]
    names: frozenset[str]

    def answer(self, connection: socket.socket, address: tuple, head: bytes) -> None:
        _Handler(head, self, connection, address)


class MonitorServer:
    """Serves the page in a background thread: ``with MonitorServer(config) as server:
    server.url``. ``port`` 0 takes a free one. Requests must name this server in their Host
    header: by IP address, as ``localhost``, or as one of ``public_names`` (request_checks)."""

    def __init__(
        self,
        config: PageConfig,
        host: str = "127.0.0.1",
        port: int = 0,
        public_names: Iterable[str] = (),
    ):
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self.listener = socket.create_server((host, port), family=family)
        self.host, self.port = host, self.listener.getsockname()[1]
        names = server_names(host, public_names)
        site = _Site(config, content_security_policy(config), static_files(), names)
        self.connections = Connections(self.listener, site.answer)
        self.thread = threading.Thread(target=self.connections.serve, name="monitor", daemon=True)

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in WILDCARD_HOSTS else self.host
        return f"http://[{host}]:{self.port}/" if ":" in host else f"http://{host}:{self.port}/"

    def __enter__(self) -> MonitorServer:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.thread.is_alive():
            self.connections.close()
            self.thread.join()
        self.listener.close()
