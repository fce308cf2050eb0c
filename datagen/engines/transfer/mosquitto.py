"""Mosquitto for datagen.

``ManagedBroker`` runs ``mosquitto -c <generated conf>`` with a username/password (generated
unless given), persistence on, and the queue/size limits raised (the configuration is written by
``mosquitto_config``; see docs/mqtt-pitfalls.md, pitfalls 1, 4 and 9): by default a private
broker for one build on a free loopback port in a temp dir; with ``data_dir`` a long-lived one
whose state survives restarts; with ``tls_cert``/``tls_key`` an extra TLS listener; with
``websockets=True`` a loopback MQTT-over-WebSockets listener and a read-only ``monitor`` user
for browsers (``datagen monitor``; needs Mosquitto built with libwebsockets, docs/monitor.md).
``run_broker_forever`` runs one in the foreground until SIGINT/SIGTERM (``datagen broker``).
Broker URLs are parsed and built in ``broker_url``. Deployment: docs/deployment.md.
"""

from __future__ import annotations

import json
import logging
import os
import pwd
import re
import secrets
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

from datagen.engines.transfer.broker_url import broker_url
from datagen.engines.transfer.connection import broker_answers
from datagen.engines.transfer.mosquitto_config import write_config
from datagen.engines.transfer.ports import free_port, port_taken
from datagen.engines.transfer.wire import DEFAULT_MAX_MESSAGE_BYTES
from datagen.errors import DatagenError

log = logging.getLogger(__name__)


class BrokerError(DatagenError, RuntimeError):
    """Mosquitto is missing, failed to start, or died."""


_WILDCARD_HOSTS = ("0.0.0.0", "", "::")
_LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
CREDENTIALS_FILE = "credentials.json"


class ManagedBroker:
    """Context manager: a running, authenticated Mosquitto.

    Without ``data_dir`` everything (config, password file, persistence, log) lives in a temp
    dir removed by ``close()``; with it, in ``data_dir``, kept, and generated credentials are
    saved there (``credentials.json``, mode 0600) so a restarted broker keeps its URL.

    With ``tls_cert``/``tls_key`` (PEM files, copied into the broker's dir) a TLS listener
    serves ``host:tls_port`` (``tls_url``); the plain listener then binds to loopback only when
    ``host`` is not a loopback address, so passwords never cross the network in clear.
    ``acl_file``: a Mosquitto ACL file (copied), e.g. to confine users to their builds' topics.
    ``password_file``: more users (a ``mosquitto_passwd`` file, copied beside ours), e.g. one
    per role of a build (docs/deployment.md, 'Least privilege').
    """

    def __init__(
        self,
        *,
        host: str = "127.0.0.1",
        port: int | None = None,
        max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
        max_queued_messages: int = 1_000_000,
        max_queued_bytes: int = 2 * 2**30,
        max_inflight_messages: int = 64,
        autosave_interval_s: int = 2,
        startup_timeout_s: float = 10.0,
        executable: str = "mosquitto",
        data_dir: str | os.PathLike | None = None,
        username: str | None = None,
        password: str | None = None,
        tls_cert: str | os.PathLike | None = None,
        tls_key: str | os.PathLike | None = None,
        tls_port: int | None = None,
        advertise_host: str | None = None,
        acl_file: str | os.PathLike | None = None,
        password_file: str | os.PathLike | None = None,
        preexec_fn: Callable[[], None] | None = None,
        websockets: bool = False,
        websockets_port: int | None = None,
        websockets_host: str = "127.0.0.1",
    ):
        if (tls_cert is None) != (tls_key is None):
            raise ValueError("tls_cert and tls_key go together")
        self.host = host
        self.port = port
        self.max_message_bytes = max_message_bytes
        self.max_queued_messages = max_queued_messages
        self.max_queued_bytes = max_queued_bytes
        self.max_inflight_messages = max_inflight_messages
        self.autosave_interval_s = autosave_interval_s
        self.startup_timeout_s = startup_timeout_s
        self.executable = executable
        self.tls_cert = Path(tls_cert) if tls_cert is not None else None
        self.tls_key = Path(tls_key) if tls_key is not None else None
        self.tls_port = tls_port
        self.acl_file = Path(acl_file) if acl_file is not None else None
        self.password_file = Path(password_file) if password_file is not None else None
        self.preexec_fn = preexec_fn
        self.websockets, self.websockets_port = websockets, websockets_port
        self.websockets_host = websockets_host
        # the browser's account: may read datagen/+/live/# only (mosquitto_config.MONITOR_ACL)
        self.monitor_username = "monitor"
        self.monitor_password = secrets.token_urlsafe(18) if websockets else None
        self._data_dir = Path(data_dir) if data_dir is not None else None
        self.dir: Path | None = None
        self.username, self.password = self._credentials(username, password)
        if host in _WILDCARD_HOSTS:
            self.advertise_host = advertise_host or socket.getfqdn()
        else:
            self.advertise_host = advertise_host or host
        self._proc: subprocess.Popen | None = None
        self._run_as: pwd.struct_passwd | None = None
        self._log_start = 0  # where this start's lines begin in the log (kept across restarts)

    @property
    def tls(self) -> bool:
        return self.tls_cert is not None

    @property
    def plain_host(self) -> str:
        """Where the plain (non-TLS) listener binds."""
        if self.tls and self.host not in _LOOPBACK_HOSTS:
            return "127.0.0.1"
        return self.host

    @property
    def url(self) -> str:
        """Plain ``mqtt://`` URL with credentials, for clients on this machine."""
        if self.port is None:
            raise BrokerError("broker not started")
        host = "127.0.0.1" if self.plain_host in _WILDCARD_HOSTS else self.plain_host
        return broker_url("mqtt", self.username, self.password, host, self.port)

    @property
    def tls_url(self) -> str:
        if not self.tls or self.tls_port is None:
            raise BrokerError("no TLS listener (pass tls_cert and tls_key) or not started")
        return broker_url("mqtts", self.username, self.password, self.advertise_host, self.tls_port)

    @property
    def public_url(self) -> str:
        """The URL other machines use: TLS when configured, else plain on ``advertise_host``."""
        if self.tls:
            return self.tls_url
        if self.port is None:
            raise BrokerError("broker not started")
        return broker_url("mqtt", self.username, self.password, self.advertise_host, self.port)

    @property
    def websockets_url(self) -> str:
        """``ws://host:port`` of the WebSockets listener (no credentials: the monitor's are
        ``monitor_username``/``monitor_password``)."""
        if not self.websockets or self.websockets_port is None:
            raise BrokerError("no WebSockets listener (pass websockets=True) or not started")
        host = "127.0.0.1" if self.websockets_host in _WILDCARD_HOSTS else self.websockets_host
        return f"ws://{host}:{self.websockets_port}"

    @property
    def pid(self) -> int | None:
        return self._proc.pid if self._proc is not None else None

    @property
    def log_path(self) -> Path:
        assert self.dir is not None
        return self.dir / "mosquitto.log"

    def __enter__(self) -> ManagedBroker:
        try:
            self.start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stops the broker; deletes its temp dir (never a ``data_dir``)."""
        self.stop()
        if self.dir is not None and self._data_dir is None:
            shutil.rmtree(self.dir, ignore_errors=True)
        self.dir = None

    def start(self) -> None:
        """Starts (or restarts, keeping ports, credentials and persisted state) the broker."""
        exe = shutil.which(self.executable)
        if exe is None:
            raise BrokerError(
                f"{self.executable!r} not found on PATH (Debian: apt-get install mosquitto)"
            )
        if self.dir is None:
            if self._data_dir is not None:
                self._data_dir.mkdir(parents=True, exist_ok=True)
                self.dir = self._data_dir
            else:
                self.dir = Path(tempfile.mkdtemp(prefix="datagen-mosquitto-"))
        if self.port is None:
            self.port = free_port(self.plain_host)
        if self.tls and self.tls_port is None:
            self.tls_port = free_port(self.host if self.host not in _WILDCARD_HOSTS else "0.0.0.0")
        if self.websockets and self.websockets_port is None:
            self.websockets_port = free_port(self.websockets_host)
        for host, port in self._listeners():
            if port_taken(host, port):
                raise BrokerError(self._taken(port))
        self._run_as = write_config(self)
        self._log_start = self.log_path.stat().st_size if self.log_path.exists() else 0
        # As root, start mosquitto as user "mosquitto" ourselves rather than letting it switch:
        # a process that changes its user loses its parent-death signal (prctl(2)), so a
        # ``preexec_fn`` setting one would not outlive mosquitto's own switch
        # (docs/mqtt-pitfalls.md, pitfall 13).
        creds: dict = {}
        if self._run_as is not None:
            creds = {"user": self._run_as.pw_uid, "group": self._run_as.pw_gid, "extra_groups": []}
        with open(self.log_path, "ab") as log_file:
            self._proc = subprocess.Popen(
                [exe, "-c", str(self.dir / "mosquitto.conf")],
                stdout=log_file,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
                preexec_fn=self.preexec_fn,
                **creds,
            )
        self._wait_listening()
        log.info("mosquitto pid %d listening on %s:%d", self._proc.pid, self.plain_host, self.port)

    def stop(self, timeout_s: float = 10.0) -> None:
        """SIGTERM (mosquitto saves its persistence file), then SIGKILL after ``timeout_s``."""
        proc, self._proc = self._proc, None
        if proc is None or proc.poll() is not None:
            return
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            log.warning("mosquitto pid %d ignored SIGTERM; killing it", proc.pid)
            proc.kill()
            proc.wait()

    def kill(self) -> None:
        """SIGKILL, as in a crash: only what autosave wrote survives."""
        proc, self._proc = self._proc, None
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def log_tail(self, lines: int = 20) -> str:
        try:
            text = self.log_path.read_text(errors="replace")
        except (OSError, AssertionError):
            return "(no log)"
        return "\n".join(text.splitlines()[-lines:])

    def _listeners(self) -> list[tuple[str, int | None]]:
        """(host, port) of each listener: plain, then TLS and WebSockets where configured."""
        found = [(self.plain_host, self.port)]
        found += [(self.host, self.tls_port)] if self.tls else []
        return found + ([(self.websockets_host, self.websockets_port)] if self.websockets else [])

    def _taken(self, port: int) -> str:
        host = next((h for h, p in self._listeners() if p == port), self.host)
        return (
            f"{host or '0.0.0.0'}:{port} is already in use (another broker or program listens "
            "there): stop it, or choose another port"
        )

    def _log_since_start(self) -> str:
        try:
            with open(self.log_path, "rb") as f:
                f.seek(self._log_start)
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def _credentials(self, username: str | None, password: str | None) -> tuple[str, str]:
        if username is not None and password is not None:
            return username, password
        saved_path = self._data_dir / CREDENTIALS_FILE if self._data_dir is not None else None
        saved = None
        if saved_path is not None and saved_path.is_file():
            saved = json.loads(saved_path.read_text(encoding="utf-8"))
        if password is None and saved and username in (None, saved["username"]):
            return saved["username"], saved["password"]
        username = username or (saved or {}).get("username") or "datagen-" + secrets.token_hex(4)
        if password is not None:
            return username, password
        password = secrets.token_urlsafe(18)
        if saved_path is not None:
            saved_path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(saved_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                json.dump({"username": username, "password": password}, f)
        return username, password

    def _wait_listening(self) -> None:
        assert self._proc is not None and self.port is not None
        host = "127.0.0.1" if self.plain_host in _WILDCARD_HOSTS else self.plain_host
        deadline = time.monotonic() + self.startup_timeout_s
        while True:
            log = self._log_since_start()  # read first: "running" is written before any exit
            if self._proc.poll() is not None:
                code = self._proc.returncode
                self._proc = None
                hint = ""
                if self.websockets:
                    hint = (
                        " (a WebSockets listener needs Mosquitto built with libwebsockets: "
                        "Debian 12's 2.0.11 is not; scripts/install.sh installs 2.0.21 from "
                        "bookworm-backports)"
                    )
                log = self._log_since_start()  # now with its last words
                if taken := re.search(r"on port (\d+)\.\n[^\n]*Address already in use", log):
                    raise BrokerError(self._taken(int(taken[1])))
                raise BrokerError(
                    f"mosquitto exited with code {code} during startup{hint}; log tail:\n{self.log_tail()}"
                )
            # Our process logged "running" (every listener open: bound, not refused) and a
            # CONNACK came: another broker on the port cannot pass for ours.
            if " running\n" in log and broker_answers(
                host, self.port, self.username, self.password, 0.5
            ):
                return
            if time.monotonic() > deadline:
                self.kill()
                raise BrokerError(
                    f"mosquitto did not accept connections on {host}:{self.port} within "
                    f"{self.startup_timeout_s} s; log tail:\n{self.log_tail()}"
                )
            time.sleep(0.05)


def run_broker_forever(
    *,
    host: str = "127.0.0.1",
    port: int = 1883,
    data_dir: str | os.PathLike | None = None,
    username: str | None = None,
    password: str | None = None,
    tls_cert: str | os.PathLike | None = None,
    tls_key: str | os.PathLike | None = None,
    advertise_host: str | None = None,
    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
    autosave_interval_s: int = 30,
    on_ready: Callable[[ManagedBroker], None] | None = None,
    stop: threading.Event | None = None,
) -> int:
    """Runs Mosquitto until SIGINT/SIGTERM (or ``stop`` is set), then stops it cleanly (it
    saves its state); returns 0. Raises BrokerError if Mosquitto fails to start or dies.

    ``port`` is the TLS port when ``tls_cert``/``tls_key`` are given (the plain listener then
    takes a free loopback port). ``on_ready(broker)`` runs once it accepts connections:
    ``broker.public_url`` is what clients use. Prints nothing; logs via ``logging``.
    """
    stop = stop or threading.Event()
    tls = tls_cert is not None
    broker = ManagedBroker(
        host=host,
        port=None if tls else port,
        tls_port=port if tls else None,
        data_dir=data_dir,
        username=username,
        password=password,
        tls_cert=tls_cert,
        tls_key=tls_key,
        advertise_host=advertise_host,
        max_message_bytes=max_message_bytes,
        autosave_interval_s=autosave_interval_s,
    )
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, lambda *_: stop.set())
    try:
        with broker:
            if on_ready is not None:
                on_ready(broker)
            while not stop.wait(0.5):
                if not broker.running:
                    raise BrokerError(f"mosquitto died; log tail:\n{broker.log_tail()}")
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
