"""The live monitor as a target (docs/monitor.md, 'What the page trusts'): its page connects
only to the broker its server names, whatever the page's address says; the build's WebSockets
listener is reachable on loopback only; and ``datagen monitor``'s HTTP server answers crafted
paths and foreign Host headers (DNS rebinding) with a 4xx, never a traceback, never
``config.json`` with the monitor's password."""

from __future__ import annotations

import base64
import ctypes
import hashlib
import json
import os
import re
import secrets
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import paho.mqtt.client as mqtt
import psutil
import pytest

from datagen.monitor.server import MonitorServer, PageConfig
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.topics import topics

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]
CHROMIUM = "/usr/bin/chromium"  # Debian's (scripts/install.sh), as tests/monitor/test_monitor.py
WEBSOCKET_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"  # RFC 6455, section 1.3


# --- `datagen monitor`'s HTTP server ---------------------------------------------------------------


def raw_get(port: int, target: str, host: str | None = "", **headers: str) -> tuple[int | None, bytes]:  # fmt: skip
    """A raw ``GET target`` to 127.0.0.1:port: (status or None when no answer came, the whole
    answer). ``host`` "" sends ``127.0.0.1:PORT``, None no Host header at all."""
    lines = [f"GET {target} HTTP/1.1"]
    if host is not None:
        lines.append(f"Host: {host or f'127.0.0.1:{port}'}")
    lines += [f"{k.replace('_', '-')}: {v}" for k, v in headers.items()]
    request = "\r\n".join([*lines, "Connection: close", "", ""]).encode("latin-1")
    answer = b""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(request)
        while chunk := s.recv(65536):
            answer += chunk
    status = re.match(rb"HTTP/1\.[01] (\d{3}) ", answer)
    return (int(status[1]) if status else None), answer


class MonitorCommand:
    """``datagen monitor --port 0`` as a user runs it, its monitor password in the environment."""

    def __init__(self):
        self.password = secrets.token_urlsafe(12)
        broker = f"ws://datagen-monitor:{self.password}@127.0.0.1:9"  # never connected to
        env = os.environ | {"DATAGEN_MONITOR_BROKER_URL": broker}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "datagen.cli", "monitor", "--port", "0", "--build-id", "b-1"],
            cwd=REPO, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )  # fmt: skip
        line = self.proc.stdout.readline()
        served = re.search(r"open http://127\.0\.0\.1:(\d+)/", line)
        assert served, line + self.proc.stderr.read()
        self.port = int(served[1])

    def get(self, target: str, host: str | None = "", **headers: str) -> tuple[int | None, bytes]:
        return raw_get(self.port, target, host, **headers)

    def stop(self) -> str:
        """Ctrl-C; what it printed on stderr."""
        self.proc.send_signal(signal.SIGINT)
        _, err = self.proc.communicate(timeout=10)
        return err


@pytest.fixture
def monitor_command():
    command = MonitorCommand()
    yield command
    if command.proc.poll() is None:
        command.proc.kill()
        command.proc.communicate()


def test_crafted_paths_get_a_4xx_and_no_traceback(monitor_command):
    crafted = [
        "/app.js%00.png",  # NUL: open() raised ValueError in the handler
        "/..%2f..%2fetc/passwd",
        "/%2e%2e/",
        "/%2e%2e/%2e%2e/etc/passwd",
        "/vendor%2fmqtt.min.js",
        "/app.js%5c..%5cconfig.json",
        "//etc/passwd",
        "/vendor/",  # a directory: no listing
        "/%ff%fe",
        "*",
    ]
    answers = {target: monitor_command.get(target) for target in crafted}
    for target, (status, answer) in answers.items():
        assert status in (400, 404), f"GET {target}: answered {status}: {answer[:200]!r}"
        assert b"root:" not in answer and b"<html" not in answer.lower(), target
    for target, kind in [("/", b"text/html"), ("/app.js", b"javascript"), ("/vendor/mqtt.min.js", b"javascript")]:  # fmt: skip
        status, answer = monitor_command.get(target)
        assert status == 200 and kind in answer.split(b"\r\n\r\n")[0], target
    err = monitor_command.stop()
    assert err == "", f"the server wrote to stderr:\n{err}"


def test_config_json_goes_only_to_a_request_naming_this_server(monitor_command):
    """DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1 reads
    ``http://evil.example:PORT/config.json`` as same-origin; its Host header gives it away."""
    port, password = monitor_command.port, monitor_command.password.encode()
    evil = f"evil.example:{port}"
    refused = {  # what -> (target, Host header or None for none, more headers)
        "Host evil.example": ("/config.json", evil, {}),
        "Host evil.example, no port": ("/config.json", "evil.example", {}),
        "Host 127.0.0.1.evil.example": ("/config.json", f"127.0.0.1.{evil}", {}),
        "Host localhost.evil.example": ("/config.json", f"localhost.{evil}", {}),
        "no Host": ("/config.json", None, {}),
        "absolute-form target": (f"http://{evil}/config.json", evil, {}),
        "a cross-site read": ("/config.json", "", {"Sec_Fetch_Site": "cross-site"}),
        "the page, Host evil.example": ("/", evil, {}),
    }
    for what, (target, host, headers) in refused.items():
        status, answer = monitor_command.get(target, host, **headers)
        assert status in (400, 403), f"{what}: answered {status}"
        assert password not in answer, f"{what}: the monitor password was served"
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LocalHost:{port}"):
        status, answer = monitor_command.get("/config.json", host)
        head, _, body = answer.partition(b"\r\n\r\n")
        assert status == 200 and json.loads(body)["password"] == monitor_command.password, host
        assert b"Cache-Control: no-store" in head
    err = monitor_command.stop()
    assert err == "", f"the server wrote to stderr:\n{err}"


def test_ctrl_c_stops_the_monitor_whichever_thread_the_kernel_gives_it_to(monitor_command):
    """SIGINT sent to the process may land on any of its threads; CPython runs the handler in
    the main thread, which must not sleep through it (an untimed wait did: the command never
    stopped when the signal landed on a server thread)."""
    proc = monitor_command.proc
    others = [int(t) for t in os.listdir(f"/proc/{proc.pid}/task") if int(t) != proc.pid]
    assert others, "the monitor serves from a thread of its own"
    assert ctypes.CDLL(None, use_errno=True).tgkill(proc.pid, others[0], signal.SIGINT) == 0
    _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0 and err == "", err


def test_a_monitor_shared_with_the_network_answers_its_names_only():
    """``--host 0.0.0.0 --public-name monitor.example.org``: by IP address, by this machine's
    host name and by the public name, yes; by any other name, no."""
    config = PageConfig("ws://127.0.0.1:9", "monitor", "s3cret")
    with MonitorServer(config, "0.0.0.0", 0, ["Monitor.Example.org"]) as server:
        port = server.port
        for host in ("monitor.example.org", f"{socket.gethostname()}:{port}", f"[::1]:{port}"):
            status, answer = raw_get(port, "/config.json", host)
            assert status == 200 and b"s3cret" in answer, host
        for host in ("evil.example", f"monitor.example.org.evil.example:{port}"):
            assert raw_get(port, "/config.json", host)[0] == 403, host


HALF_REQUEST = b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n"  # no blank line: it never ends
MAX_TASKS = 16  # threads of the whole `datagen monitor` process, main thread included


def tasks(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/task"))


def hang_up_while_answered(port: int) -> None:
    """A whole request for the largest file, then a reset before a byte of it is read: the
    server's write fails (ECONNRESET or EPIPE)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        s.sendall(f"GET /vendor/mqtt.min.js HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())


def test_idle_half_requests_hold_no_threads_and_lock_nobody_out(monitor_command):
    """Issue 38, low 14: 300 connections that each send half a request and wait made 188
    threads, and clients that hung up wrote BrokenPipeError lines on the terminal."""
    pid, port = monitor_command.proc.pid, monitor_command.port
    idle = []
    for _ in range(300):
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        s.sendall(HALF_REQUEST)
        idle.append(s)
    peak, deadline = tasks(pid), time.monotonic() + 2
    while time.monotonic() < deadline:  # the server takes them in meanwhile
        peak = max(peak, tasks(pid))
        time.sleep(0.05)
    status, answer = monitor_command.get("/")  # a well-behaved client, during all that
    assert status == 200 and b"<html" in answer.lower()
    for _ in range(20):
        hang_up_while_answered(port)
    assert monitor_command.get("/app.js")[0] == 200
    peak = max(peak, tasks(pid))
    assert peak <= MAX_TASKS, f"{peak} threads for 300 idle connections"
    dropped = 0
    for s in idle:  # each dropped by the server in bounded time (its read time-out)
        s.settimeout(30)
        try:
            dropped += s.recv(1) == b""
        except ConnectionResetError:
            dropped += 1
        s.close()
    assert dropped == len(idle)
    err = monitor_command.stop()
    assert "Error" not in err and err == "", f"the server wrote to stderr:\n{err[-2000:]}"


# --- the build's WebSockets listener ---------------------------------------------------------------


def _other_addresses() -> list[str]:
    """This machine's addresses other than 127.0.0.1 (::1 and every interface's)."""
    found = ["::1"]
    for addresses in psutil.net_if_addrs().values():
        for a in addresses:
            if a.family in (socket.AF_INET, socket.AF_INET6) and not a.address.startswith(("127.", "fe80")):  # fmt: skip
                found.append(a.address.split("%")[0])
    return sorted(set(found))


@pytest.mark.mqtt
def test_the_websockets_listener_is_bound_to_loopback_only():
    """Mosquitto 2.0.21 hands a WebSockets listener's address to libwebsockets, which bound
    ``listener PORT 127.0.0.1`` on [::], every interface, unless told the socket is IPv4."""
    with ManagedBroker(BrokerSettings(websockets=True)) as broker:
        port = broker.websockets_port
        bound = {
            c.laddr.ip
            for c in psutil.net_connections("tcp")
            if c.status == psutil.CONN_LISTEN and c.laddr.port == port
        }
        assert bound == {"127.0.0.1"}, f"the WebSockets listener is bound on {sorted(bound)}"
        answered = []
        for address in _other_addresses():
            try:
                socket.create_connection((address, port), timeout=1).close()
                answered.append(address)
            except OSError:
                pass
        assert answered == [], f"the WebSockets listener answered on {answered}"
        socket.create_connection(("127.0.0.1", port), timeout=1).close()


# --- the page in a real browser --------------------------------------------------------------------


class WebSocketRecorder:
    """A WebSockets server on a free loopback port that accepts any MQTT-over-WebSockets
    client and records what it sends: the broker an attacker names in the page's address."""

    def __init__(self):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.received: list[bytes] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            threading.Thread(target=self._record, args=(conn,), daemon=True).start()

    def _record(self, conn: socket.socket) -> None:
        conn.settimeout(5)
        data = b""
        try:
            while b"\r\n\r\n" not in data and (chunk := conn.recv(4096)):
                data += chunk
            self.received.append(data)
            key = re.search(rb"Sec-WebSocket-Key: *(\S+)", data, re.I)
            if key is None:
                return
            accept = base64.b64encode(hashlib.sha1(key[1] + WEBSOCKET_GUID.encode()).digest())
            conn.sendall(b"HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\n"
                         b"Connection: Upgrade\r\nSec-WebSocket-Protocol: mqtt\r\n"
                         b"Sec-WebSocket-Accept: " + accept + b"\r\n\r\n")  # fmt: skip
            frame = conn.recv(65536)  # the client's first frame: its MQTT CONNECT, masked
            length, at = frame[1] & 0x7F, 2
            if length == 126:
                length, at = int.from_bytes(frame[2:4], "big"), 4
            mask, payload = frame[at : at + 4], frame[at + 4 : at + 4 + length]
            self.received.append(bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))
        except OSError:
            pass
        finally:
            conn.close()

    def close(self) -> None:
        self.sock.close()


@pytest.mark.mqtt
@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian's chromium (scripts/install.sh)")
def test_the_page_connects_only_to_its_servers_broker_whatever_its_address_says():
    """The page opened as ``/?broker=ws://ATTACKER&user=x``: before, it connected there and
    sent the monitor's own password (the URL named no password). It must connect to the
    broker of its config.json, say it ignored the parameters, and use a random client id."""
    from playwright.sync_api import sync_playwright

    recorder = WebSocketRecorder()
    build = "page-" + secrets.token_hex(4)
    with ManagedBroker(BrokerSettings(websockets=True)) as broker:
        config = PageConfig(broker.websockets_url, broker.monitor_username, broker.monitor_password or "", build)  # fmt: skip
        publisher = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5)
        publisher.username_pw_set(broker.username, broker.password)
        publisher.connect("127.0.0.1", broker.port)
        publisher.loop_start()
        status = {"state": "running", "message": "running: 1/2 durable", "durable": 1, "total": 2}
        publisher.publish(topics(build).live_status, json.dumps(status), qos=1, retain=True).wait_for_publish(5)  # fmt: skip
        with MonitorServer(config) as server, sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
            try:
                page = browser.new_page()
                refused = []  # what the page's Content-Security-Policy stopped: nothing it needs
                page.on("console", lambda m: refused.append(m.text) if "Content Security" in m.text else None)  # fmt: skip
                page.on("pageerror", lambda e: refused.append(str(e)))
                page.goto(f"{server.url}?broker=ws://127.0.0.1:{recorder.port}&user=x")
                deadline = time.monotonic() + 20
                while time.monotonic() < deadline and not recorder.received:
                    if page.inner_text("#state") == status["message"]:
                        break
                    time.sleep(0.1)
                time.sleep(0.5)  # a second connection attempt has had the time to arrive
                sent = b"".join(recorder.received)
                assert not recorder.received, (
                    f"the page connected to the broker its address named"
                    f"{' and sent it the monitor password' if config.password.encode() in sent else ''}"
                )
                assert page.inner_text("#state") == status["message"]
                assert page.inner_text("#connection") == f"connected to {broker.websockets_url}"
                assert refused == []
                notice = page.inner_text("#notice")
                assert "ignored" in notice and "broker" in notice and "user" in notice, notice
            finally:
                browser.close()
                recorder.close()
                publisher.disconnect()
                publisher.loop_stop()
        clients = re.findall(r" as (\S+) \(p5, .*u'monitor'\)", broker.log_path.read_text())
    assert clients and all(re.fullmatch(r"datagen-monitor-[0-9a-f]{32}", c) for c in clients), clients  # fmt: skip
