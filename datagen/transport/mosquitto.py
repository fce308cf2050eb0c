"""Mosquitto for datagen.

``ManagedBroker`` runs ``mosquitto -c <generated conf>`` with the :class:`BrokerSettings` it is
given (listeners, limits, users, state; the configuration is written by ``mosquitto_config``;
docs/mqtt-pitfalls.md, pitfalls 1, 4 and 9): by default a private broker for one build on a
free loopback port in a temp dir. A WebSockets listener (``websockets=True``) adds a read-only
``monitor`` user for browsers (``datagen monitor``; needs Mosquitto built with libwebsockets,
docs/monitor.md). ``broker_service.run_broker_forever`` runs one in the foreground
(``datagen broker``). Broker URLs are parsed and built in ``broker_url``.
"""

from __future__ import annotations

import logging
import pwd
import re
import secrets
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from datagen.errors import DatagenError
from datagen.transport.broker_credentials import broker_credentials
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.broker_url import broker_url
from datagen.transport.connection import broker_answers
from datagen.transport.mosquitto_config import write_config
from datagen.transport.ports import free_port, port_taken

log = logging.getLogger(__name__)


class BrokerError(DatagenError, RuntimeError):
    """Mosquitto is missing, failed to start, or died."""


_WILDCARD_HOSTS = ("0.0.0.0", "", "::")
_LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")


class ManagedBroker:
    """Context manager: a running, authenticated Mosquitto with ``settings``
    (:class:`BrokerSettings`; the defaults: a private broker for one build on a free loopback
    port in a temp dir).

    Without ``settings.data_dir`` everything (config, password file, persistence, log) lives in
    a temp dir removed by ``close()``; with it, in ``data_dir``, kept, and generated credentials
    are saved there (``credentials.json``, mode 0600) so a restarted broker keeps its URL.
    ``preexec_fn`` runs in the child before Mosquitto starts (the coordinator asks for a
    parent-death signal there).
    """

    def __init__(
        self,
        settings: BrokerSettings | None = None,
        *,
        preexec_fn: Callable[[], None] | None = None,
    ):
        self.settings = settings = settings or BrokerSettings()
        self.preexec_fn = preexec_fn
        # chosen at the first start where the settings leave them open, kept across restarts
        self.port = settings.port
        self.tls_port = settings.tls_port
        self.websockets_port = settings.websockets_port
        # the browser's account: may read datagen/+/live/# only (mosquitto_config.MONITOR_ACL)
        self.monitor_username = "monitor"
        self.monitor_password = secrets.token_urlsafe(18) if settings.websockets else None
        self.dir: Path | None = None
        self.username, self.password = broker_credentials(
            settings.data_dir, settings.username, settings.password
        )
        if settings.host in _WILDCARD_HOSTS:
            self.advertise_host = settings.advertise_host or socket.getfqdn()
        else:
            self.advertise_host = settings.advertise_host or settings.host
        self._proc: subprocess.Popen | None = None
        self._run_as: pwd.struct_passwd | None = None
        self._log_start = 0  # where this start's lines begin in the log (kept across restarts)

    @property
    def tls(self) -> bool:
        return self.settings.tls

    @property
    def plain_host(self) -> str:
        """Where the plain (non-TLS) listener binds."""
        if self.tls and self.settings.host not in _LOOPBACK_HOSTS:
            return "127.0.0.1"
        return self.settings.host

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
        host = self.settings.websockets_host
        if not self.settings.websockets or self.websockets_port is None:
            raise BrokerError("no WebSockets listener (pass websockets=True) or not started")
        host = "127.0.0.1" if host in _WILDCARD_HOSTS else host
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
        if self.dir is not None and self.settings.data_dir is None:
            shutil.rmtree(self.dir, ignore_errors=True)
        self.dir = None

    def start(self) -> None:
        """Starts (or restarts, keeping ports, credentials and persisted state) the broker."""
        settings = self.settings
        exe = shutil.which(settings.executable)
        if exe is None:
            raise BrokerError(
                f"{settings.executable!r} not found on PATH (Debian: apt-get install mosquitto)"
            )
        if self.dir is None:
            if settings.data_dir is not None:
                settings.data_dir.mkdir(parents=True, exist_ok=True)
                self.dir = settings.data_dir
            else:
                self.dir = Path(tempfile.mkdtemp(prefix="datagen-mosquitto-"))
        if self.port is None:
            self.port = free_port(self.plain_host)
        if self.tls and self.tls_port is None:
            host = settings.host if settings.host not in _WILDCARD_HOSTS else "0.0.0.0"
            self.tls_port = free_port(host)
        if settings.websockets and self.websockets_port is None:
            self.websockets_port = free_port(settings.websockets_host)
        for host, port in self._listeners():
            assert port is not None  # every listener's port was chosen above
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
        settings = self.settings
        found = [(self.plain_host, self.port)]
        found += [(settings.host, self.tls_port)] if self.tls else []
        websockets = [(settings.websockets_host, self.websockets_port)]
        return found + (websockets if settings.websockets else [])

    def _taken(self, port: int) -> str:
        host = next((h for h, p in self._listeners() if p == port), self.settings.host)
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

    def _wait_listening(self) -> None:
        assert self._proc is not None and self.port is not None
        host = "127.0.0.1" if self.plain_host in _WILDCARD_HOSTS else self.plain_host
        deadline = time.monotonic() + self.settings.startup_timeout_s
        while True:
            log = self._log_since_start()  # read first: "running" is written before any exit
            if self._proc.poll() is not None:
                code = self._proc.returncode
                self._proc = None
                hint = ""
                if self.settings.websockets:
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
                    f"{self.settings.startup_timeout_s} s; log tail:\n{self.log_tail()}"
                )
            time.sleep(0.05)
