"""A private Mosquitto broker for one build, and broker URL parsing.

``ManagedBroker`` runs ``mosquitto -c <generated conf>`` on a free loopback port with a
generated username/password, persistence on, and the queue/size limits raised (see
/work/shared/notes/mqtt.md, pitfalls 1, 4 and 9).
"""

from __future__ import annotations

import base64
import hashlib
import logging
import os
import pwd
import secrets
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote, unquote, urlsplit

from datagen.engines.wire import DEFAULT_MAX_MESSAGE_BYTES

log = logging.getLogger(__name__)

# Room for the topic, properties and fixed header around the largest payload.
PACKET_OVERHEAD_BYTES = 64 * 1024


class BrokerError(RuntimeError):
    """Mosquitto is missing, failed to start, or died."""


@dataclass(frozen=True)
class BrokerAddress:
    host: str
    port: int
    username: str | None
    password: str | None
    tls: bool


def parse_broker_url(url: str) -> BrokerAddress:
    """``mqtt://[user[:pass]@]host[:port]`` (default port 1883) or ``mqtts://`` (8883)."""
    try:
        parts = urlsplit(url)
        port = parts.port
    except ValueError as exc:
        raise ValueError(f"bad broker URL {url!r}: {exc}") from None
    if parts.scheme not in ("mqtt", "mqtts"):
        raise ValueError(f"bad broker URL {url!r}: scheme must be mqtt:// or mqtts://")
    if not parts.hostname:
        raise ValueError(f"bad broker URL {url!r}: no host")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(f"bad broker URL {url!r}: unexpected path, query or fragment")
    tls = parts.scheme == "mqtts"
    return BrokerAddress(
        host=parts.hostname,
        port=port if port is not None else (8883 if tls else 1883),
        username=unquote(parts.username) if parts.username is not None else None,
        password=unquote(parts.password) if parts.password is not None else None,
        tls=tls,
    )


def mosquitto_password_hash(password: str, iterations: int = 101) -> str:
    """Mosquitto 2.x ``$7$`` entry: PBKDF2-HMAC-SHA512, 12-byte salt, as mosquitto_passwd writes."""
    salt = secrets.token_bytes(12)
    digest = hashlib.pbkdf2_hmac("sha512", password.encode("utf-8"), salt, iterations)
    b64 = base64.b64encode
    return f"$7${iterations}${b64(salt).decode()}${b64(digest).decode()}"


def _mqtt_str(text: str) -> bytes:
    raw = text.encode("utf-8")
    return len(raw).to_bytes(2, "big") + raw


def mqtt_handshake(host: str, port: int, username: str, password: str, timeout_s: float) -> bool:
    """True if an MQTT broker answers a CONNECT on host:port with a CONNACK (any return code)."""
    body = _mqtt_str("MQTT") + bytes(
        [4, 0xC2, 0, 10]
    )  # v3.1.1, user+password+clean, keepalive 10 s
    body += _mqtt_str("") + _mqtt_str(username) + _mqtt_str(password)
    remaining, n = b"", len(body)
    while True:
        n, digit = divmod(n, 128)
        remaining += bytes([digit | (0x80 if n else 0)])
        if not n:
            break
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as s:
            s.sendall(b"\x10" + remaining + body)
            answer = s.recv(4)
            s.sendall(b"\xe0\x00")  # DISCONNECT
    except OSError:
        return False
    return answer[:2] == b"\x20\x02"


def _free_port(host: str) -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


class ManagedBroker:
    """Context manager: a running, authenticated Mosquitto in a private temp dir."""

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
    ):
        self.host = host
        self.port = port
        self.max_message_bytes = max_message_bytes
        self.max_queued_messages = max_queued_messages
        self.max_queued_bytes = max_queued_bytes
        self.max_inflight_messages = max_inflight_messages
        self.autosave_interval_s = autosave_interval_s
        self.startup_timeout_s = startup_timeout_s
        self.executable = executable
        self.username = "datagen-" + secrets.token_hex(4)
        self.password = secrets.token_urlsafe(18)
        self.dir: Path | None = None
        self._proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        if self.port is None:
            raise BrokerError("broker not started")
        return (
            f"mqtt://{quote(self.username)}:{quote(self.password, safe='')}@{self.host}:{self.port}"
        )

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
        """Stops the broker and deletes its temp dir (config, password file, persistence)."""
        self.stop()
        if self.dir is not None:
            shutil.rmtree(self.dir, ignore_errors=True)
            self.dir = None

    def start(self) -> None:
        """Starts (or restarts, keeping port, credentials and persisted state) the broker."""
        exe = shutil.which(self.executable)
        if exe is None:
            raise BrokerError(
                f"{self.executable!r} not found on PATH (Debian: apt-get install mosquitto)"
            )
        if self.dir is None:
            self.dir = Path(tempfile.mkdtemp(prefix="datagen-mosquitto-"))
            self._write_config()
        if self.port is None:
            self.port = _free_port(self.host)
            self._write_config()
        with open(self.log_path, "ab") as log_file:
            self._proc = subprocess.Popen(
                [exe, "-c", str(self.dir / "mosquitto.conf")],
                stdout=log_file,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        self._wait_listening()
        log.info("mosquitto pid %d listening on %s:%d", self._proc.pid, self.host, self.port)

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

    def _write_config(self) -> None:
        assert self.dir is not None
        d = self.dir
        (d / "data").mkdir(exist_ok=True)
        (d / "passwd").write_text(
            f"{self.username}:{mosquitto_password_hash(self.password)}\n", encoding="utf-8"
        )
        os.chmod(d / "passwd", 0o600)
        lines = [
            f"listener {self.port or 1883} {self.host}",
            "allow_anonymous false",
            f"password_file {d / 'passwd'}",
            "persistence true",
            f"persistence_location {d / 'data'}/",
            f"autosave_interval {self.autosave_interval_s}",
            f"max_queued_messages {self.max_queued_messages}",
            f"max_queued_bytes {self.max_queued_bytes}",
            f"max_inflight_messages {self.max_inflight_messages}",
            f"max_packet_size {self.max_message_bytes + PACKET_OVERHEAD_BYTES}",
            "set_tcp_nodelay true",
            "log_dest stderr",
            "log_type error",
            "log_type warning",
            "log_type notice",
            "log_type information",
            "connection_messages true",
            "log_timestamp_format %Y-%m-%dT%H:%M:%S",
        ]
        if os.geteuid() == 0:
            lines.append(self._root_user_line())
        (d / "mosquitto.conf").write_text("\n".join(lines) + "\n", encoding="utf-8")

    def _root_user_line(self) -> str:
        # Mosquitto started as root drops to user "mosquitto": its files must be that user's.
        assert self.dir is not None
        try:
            entry = pwd.getpwnam("mosquitto")
        except KeyError:
            return "user root"
        for path in [self.dir, self.dir / "data", self.dir / "passwd"]:
            os.chown(path, entry.pw_uid, entry.pw_gid)
        return "user mosquitto"

    def _wait_listening(self) -> None:
        assert self._proc is not None and self.port is not None
        deadline = time.monotonic() + self.startup_timeout_s
        while True:
            if self._proc.poll() is not None:
                code = self._proc.returncode
                self._proc = None
                raise BrokerError(
                    f"mosquitto exited with code {code} during startup; log tail:\n{self.log_tail()}"
                )
            # A CONNACK, not just an open port: something else may hold the port.
            if mqtt_handshake(self.host, self.port, self.username, self.password, 0.5):
                return
            if time.monotonic() > deadline:
                self.kill()
                raise BrokerError(
                    f"mosquitto did not accept connections on {self.host}:{self.port} within "
                    f"{self.startup_timeout_s} s; log tail:\n{self.log_tail()}"
                )
            time.sleep(0.05)
