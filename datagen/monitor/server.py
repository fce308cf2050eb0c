"""The monitor page's web server: the static page of this package (``static/``) and one
generated ``config.json`` (which broker to connect to, as whom, and which build), on
127.0.0.1 by default. The page itself talks to the broker over MQTT-over-WebSockets
(docs/monitor.md); this server never touches MQTT.
"""

from __future__ import annotations

import json
import threading
from dataclasses import asdict, dataclass
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from importlib.resources import files
from pathlib import Path
from urllib.parse import unquote, urlsplit

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
            f"--broker {_redacted(broker_url)}: expected a WebSockets URL, ws://host:port or "
            f"wss://host:port (the broker's websockets listener, not its mqtt:// port)"
        )
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None:
        raise ValueError(f"--broker {_redacted(broker_url)}: expected ws[s]://host:port")
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    url = f"{parts.scheme}://{host}:{port}{parts.path}"
    return PageConfig(
        url, unquote(parts.username or ""), unquote(parts.password or ""), build_id or ""
    )


def _redacted(url: str) -> str:
    parts = urlsplit(url)
    if parts.password is None:
        return url
    return url.replace(f":{parts.password}@", ":***@", 1)


class _Handler(SimpleHTTPRequestHandler):
    def __init__(self, *args, config: PageConfig, **kwargs):
        self.page_config = config
        super().__init__(*args, directory=str(STATIC), **kwargs)

    def do_GET(self) -> None:
        if urlsplit(self.path).path == "/config.json":
            body = json.dumps(asdict(self.page_config)).encode("utf-8")
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Cache-Control", "no-store")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
            return
        super().do_GET()

    def log_message(self, format: str, *args) -> None:  # quiet: the terminal is the build's
        pass


class MonitorServer:
    """Serves the page in a background thread: ``with MonitorServer(config) as server:
    server.url``. ``port`` 0 takes a free one."""

    def __init__(self, config: PageConfig, host: str = "127.0.0.1", port: int = 0):
        handler = partial(_Handler, config=config)
        self.httpd = ThreadingHTTPServer((host, port), handler)
        self.httpd.daemon_threads = True
        self.host, self.port = host, self.httpd.server_address[1]
        self.thread = threading.Thread(target=self.httpd.serve_forever, name="monitor", daemon=True)

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in ("", "0.0.0.0") else self.host
        return f"http://{host}:{self.port}/"

    def __enter__(self) -> MonitorServer:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
