from __future__ import annotations

import os
import pwd
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.broker_url import broker_url, parse_broker_url, redact
from datagen.transport.collector import AckCollector
from datagen.transport.connection import MqttConnectError, MqttConnection, broker_answers
from datagen.transport.mosquitto import BrokerError, ManagedBroker
from datagen.transport.publisher import PublishRefused, PublishTimeout, SamplePublisher
from datagen.transport.topics import topics
from datagen.transport.wire import decode_sample, encode_sample


def test_parse_broker_url():
    a = parse_broker_url("mqtt://u%40x:p%2Fw%3A@127.0.0.1:1999")
    assert (a.host, a.port, a.username, a.password, a.tls) == (
        "127.0.0.1",
        1999,
        "u@x",
        "p/w:",
        False,
    )
    b = parse_broker_url("mqtts://broker.example")
    assert (b.port, b.username, b.password, b.tls) == (8883, None, None, True)
    assert parse_broker_url("mqtt://h").port == 1883


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("http://h:1", "scheme"),
        ("h:1883", "scheme"),
        ("mqtt://", "no host"),
        ("mqtt://h:port", "bad broker URL"),
        ("mqtt://h:99999", "bad broker URL"),
        ("mqtt://h:1/topic", "path"),
    ],
)
def test_parse_broker_url_rejects(url, reason):
    with pytest.raises(ValueError, match=reason):
        parse_broker_url(url)


@pytest.mark.parametrize(
    ("url", "printed"),
    [
        ("mqtt://u%40x:p%2Fw%3A@127.0.0.1:1999", "mqtt://u%40x:***@127.0.0.1:1999"),
        ("mqtts://user:pa@ss@[::1]:8883/", "mqtts://user:***@[::1]:8883/"),
        ("mqtt://u:secret@h:port", "mqtt://u:***@h:port"),  # malformed, still redacted
        ("mqtt://user@h:1883", "mqtt://user@h:1883"),
        ("mqtt://h", "mqtt://h"),
        ("not a url", "not a url"),
        ("mqtt://u:pa/ss#w?@h:1", "mqtt://u:***@h:1"),  # unencoded '/', '#', '?'
        ("u:secret@h:1883", "u:***@h:1883"),  # no scheme
    ],
)
def test_redact_hides_the_password(url, printed):
    assert redact(url) == printed


@pytest.mark.parametrize(
    "url",
    ["mqtt://u:Qz7/Wk9@h:1", "mqtt://u:Qz7#Wk9@h", "mqtt://u:Qz7Wk9@h:99999", "mqtt://u:Qz7Wk9@h:x",
     "u:Qz7Wk9@h:1", "http://u:Qz7Wk9@h", "mqtt://u:Qz7Wk9@[::1:1", "mqtt://u:Qz7?Wk9@h/t"],
)  # fmt: skip
def test_a_bad_url_is_refused_without_showing_any_piece_of_its_password(url):
    with pytest.raises(ValueError, match="bad broker URL") as refused:
        parse_broker_url(url)
    assert "Qz" not in str(refused.value) and "Wk" not in str(refused.value)


def test_broker_url_round_trips_through_the_parser():
    url = broker_url("mqtts", "u@x", "p/w:", "::1", 8883)
    assert url == "mqtts://u%40x:p%2Fw%3A@[::1]:8883"
    a = parse_broker_url(url)
    assert (a.host, a.port, a.username, a.password, a.tls) == ("::1", 8883, "u@x", "p/w:", True)


@pytest.mark.mqtt
def test_broker_answers_any_connack_and_nothing_else(broker):
    a = parse_broker_url(broker.url)
    assert broker_answers(a.host, a.port, a.username, a.password, 2.0)
    assert broker_answers(a.host, a.port, a.username, "wrong", 2.0)  # a refusal is an answer
    with socket.socket() as closed:
        closed.bind(("127.0.0.1", 0))
        port = closed.getsockname()[1]
    assert not broker_answers("127.0.0.1", port, "u", "p", 0.5)  # nothing listens
    with socket.socket() as silent:  # listens, never answers
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        t0 = time.monotonic()
        assert not broker_answers("127.0.0.1", silent.getsockname()[1], "u", "p", 0.3)
        assert time.monotonic() - t0 < 2.0


@pytest.mark.mqtt
def test_broker_requires_its_credentials(broker):
    conn = MqttConnection(broker.url, "test-auth-ok")
    conn.close()
    addr = parse_broker_url(broker.url)
    for url in (
        f"mqtt://{addr.username}:wrong@{addr.host}:{addr.port}",
        f"mqtt://{addr.host}:{addr.port}",
    ):
        with pytest.raises(MqttConnectError, match="refused"):
            MqttConnection(url, "test-auth-bad")


@pytest.mark.mqtt
def test_config_raises_limits_and_files_belong_to_the_broker_user(broker):
    conf = (broker.dir / "mosquitto.conf").read_text()
    for line in (
        "allow_anonymous false",
        "persistence true",
        "max_queued_messages 1000000",
        f"max_packet_size {broker.settings.max_message_bytes + 64 * 1024}",
        "max_queued_bytes",
        "max_inflight_messages",
        "autosave_interval",
    ):
        assert line in conf
    if os.geteuid() == 0:
        owner = pwd.getpwuid((broker.dir / "data").stat().st_uid).pw_name
        assert owner == ("mosquitto" if "user mosquitto" in conf else "root")


def test_missing_executable_is_a_clear_error():
    with (
        pytest.raises(BrokerError, match="not found on PATH"),
        ManagedBroker(BrokerSettings(executable="no-such-mosquitto")),
    ):
        pass


@pytest.mark.mqtt
def test_failed_start_reports_the_log_tail_and_a_taken_port_in_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        b = ManagedBroker(BrokerSettings(port=port))
        with pytest.raises(BrokerError, match=rf"^127\.0\.0\.1:{port} is already in use"), b:
            pass
    assert b.dir is None  # temp dir removed
    b = ManagedBroker(
        BrokerSettings(host="192.0.2.1", port=port)
    )  # an address (TEST-NET-1) no interface has
    with pytest.raises(BrokerError, match=r"(?s)exited with code.*log tail:.*Cannot assign"), b:
        pass
    assert b.dir is None


@pytest.mark.mqtt
def test_stop_removes_the_temp_dir():
    with ManagedBroker() as b:
        d = b.dir
        assert d.is_dir() and b.running
    assert not d.exists() and not b.running


@pytest.mark.mqtt
def test_persistent_session_gets_messages_queued_across_a_broker_restart(make_sample):
    got: list[bytes] = []
    three = threading.Semaphore(0)

    def on_message(msg):
        got.append(msg.payload)
        three.release()

    with ManagedBroker() as b:
        t = topics("restart")
        sub = MqttConnection(
            b.url, "test-persistent", subscriptions=[(t.samples, 1)], session_expiry_s=600
        )
        sub.close()  # away; the broker keeps the session and queues for it
        with SamplePublisher(b.url, "restart", "test-pub") as pub:
            for i in range(3):
                pub.publish(make_sample(i))
        b.stop()  # SIGTERM: mosquitto writes its persistence file
        b.start()
        sub = MqttConnection(
            b.url,
            "test-persistent",
            subscriptions=[(t.samples, 1)],
            session_expiry_s=600,
            on_message=on_message,
        )
        for _ in range(3):
            assert three.acquire(timeout=20)
        sub.close(end_session=True)
    assert sorted(decode_sample(p)[1].index for p in got) == [0, 1, 2]


@pytest.mark.mqtt
def test_mosquitto_sub_hex_capture_decodes_per_spec(broker, build_id, make_sample):
    """A retained sample is delivered on subscribe, so no race with mosquitto_sub's start."""
    t = topics(build_id)
    payload = encode_sample(build_id, make_sample(5))
    conn = MqttConnection(broker.url, "test-hex")
    conn.client.publish(t.samples, payload, qos=1, retain=True).wait_for_publish(10)
    a = parse_broker_url(broker.url)
    out = subprocess.run(
        [
            *("mosquitto_sub", "-V", "mqttv5", "-h", a.host, "-p", str(a.port)),
            *("-u", a.username, "-P", a.password, "-t", t.samples, "-C", "1", "-F", "%x"),
        ],
        capture_output=True,
        text=True,
        timeout=20,
        check=True,
    ).stdout
    conn.client.publish(t.samples, b"", qos=1, retain=True).wait_for_publish(10)  # clear it
    conn.close()
    assert bytes.fromhex(out.strip()) == payload
    assert decode_sample(bytes.fromhex(out.strip()))[1].key == "000000005"


# --- TLS ---------------------------------------------------------------------------------------


def _openssl(*args, cwd):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True, timeout=60)


@pytest.fixture(scope="module")
def tls_files(tmp_path_factory):
    """A throwaway CA, a server certificate for DNS name ``localhost`` signed by it, and a
    second, unrelated CA."""
    d = tmp_path_factory.mktemp("tls")
    ec = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes")
    for ca in ("ca", "other-ca"):
        _openssl("req", "-x509", *ec, "-keyout", f"{ca}.key", "-out", f"{ca}.crt",
                 "-days", "2", "-subj", f"/CN=datagen test {ca}", cwd=d)  # fmt: skip
    _openssl("req", *ec, "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=localhost",
             cwd=d)  # fmt: skip
    (d / "san.ext").write_text("subjectAltName=DNS:localhost\n")
    _openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key",
             "-CAcreateserial", "-out", "server.crt", "-days", "2", "-extfile", "san.ext",
             cwd=d)  # fmt: skip
    return d


@pytest.fixture(scope="module")
def tls_broker(tls_files):
    with ManagedBroker(
        BrokerSettings(
            tls_cert=tls_files / "server.crt",
            tls_key=tls_files / "server.key",
            advertise_host="localhost",
        )
    ) as b:
        yield b


@pytest.mark.mqtt
def test_tls_publish_and_receive_and_a_writer_over_mqtts(
    tls_broker, tls_files, build_id, start_writer, make_sample
):
    url, ca = tls_broker.tls_url, str(tls_files / "ca.crt")
    assert url.startswith("mqtts://") and f"@localhost:{tls_broker.tls_port}" in url
    got = threading.Semaphore(0)
    sub = MqttConnection(
        url, "tls-sub", subscriptions=[("tls/test", 1)], on_message=lambda m: got.release(),
        ca_file=ca,
    )  # fmt: skip
    sub.client.publish("tls/test", b"hello", qos=1).wait_for_publish(10)
    assert got.acquire(timeout=20)
    sub.close()

    with AckCollector(url, build_id, ca_file=ca) as acks:
        w = start_writer(broker_url=url, args=["--ca-file", ca])
        acks.wait_status("ready", writer="0", timeout_s=30)
        with SamplePublisher(url, build_id, "tls-pub", ca_file=ca) as pub:
            for i in range(3):
                pub.publish(make_sample(i))
        assert acks.wait_acked(range(3), timeout_s=30), w.log()
        assert acks.finalize(3, {}, writers=["0"])["state"] == "finalized"
    assert w.wait() == 0


@pytest.mark.mqtt
def test_the_ca_file_can_come_from_the_environment(tls_broker, tls_files, monkeypatch):
    monkeypatch.setenv("DATAGEN_MQTT_CA_FILE", str(tls_files / "ca.crt"))
    MqttConnection(tls_broker.tls_url, "tls-env").close()


@pytest.mark.mqtt
def test_tls_errors_say_what_went_wrong(tls_broker, tls_files):
    a = parse_broker_url(tls_broker.tls_url)
    ca, other = str(tls_files / "ca.crt"), str(tls_files / "other-ca.crt")
    where = f"localhost:{a.port}"
    with pytest.raises(MqttConnectError, match=f"TLS verification failed for {where}: .*issuer"):
        MqttConnection(tls_broker.tls_url, "tls-wrong-ca", ca_file=other)
    # the certificate names localhost, not 127.0.0.1: host names are checked
    by_ip = f"mqtts://{a.username}:{a.password}@127.0.0.1:{a.port}"
    with pytest.raises(MqttConnectError, match=r"TLS verification failed for 127\.0\.0\.1:.*"):
        MqttConnection(by_ip, "tls-wrong-host", ca_file=ca)
    bad_password = f"mqtts://{a.username}:nope@localhost:{a.port}"
    with pytest.raises(MqttConnectError, match="broker refused the credentials"):
        MqttConnection(bad_password, "tls-bad-password", ca_file=ca)
    with pytest.raises(MqttConnectError, match=r"cannot reach .*is that port a TLS listener"):
        MqttConnection(
            f"mqtts://u:p@127.0.0.1:{tls_broker.port}", "tls-on-plain", ca_file=ca, timeout_s=2
        )
    with pytest.raises(MqttConnectError, match="does not exist"):
        MqttConnection(tls_broker.tls_url, "tls-no-ca", ca_file=str(tls_files / "missing.crt"))


def test_an_unreachable_broker_is_a_clear_error():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens there
    with pytest.raises(MqttConnectError, match=f"cannot reach broker 127.0.0.1:{port} within"):
        MqttConnection(f"mqtt://u:p@127.0.0.1:{port}", "nobody-home", timeout_s=1)


@pytest.mark.mqtt
def test_a_wrong_password_is_refused_clearly(broker):
    a = parse_broker_url(broker.url)
    with pytest.raises(MqttConnectError, match=f"broker refused the credentials .*{a.username}"):
        MqttConnection(f"mqtt://{a.username}:wrong@{a.host}:{a.port}", "bad-password")


# --- a long-running broker (datagen broker) ----------------------------------------------------


def _run_broker_process(port, data_dir):
    code = (
        "from datagen.transport.broker_service import run_broker_forever\n"
        "from datagen.transport.broker_settings import service_settings\n"
        f"settings = service_settings(port={port}, data_dir={str(data_dir)!r})\n"
        "raise SystemExit(run_broker_forever(settings, "
        "on_ready=lambda b: print(b.public_url, flush=True)))"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    url = proc.stdout.readline().strip()
    assert url.startswith("mqtt://"), proc.stderr.read()
    return proc, url


@pytest.mark.mqtt
def test_run_broker_forever_keeps_state_and_credentials_in_its_data_dir(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc, url = _run_broker_process(port, tmp_path / "broker")
    try:
        assert url.endswith(f"@127.0.0.1:{port}")
        conn = MqttConnection(url, "forever-pub")
        conn.client.publish("keep/me", b"42", qos=1, retain=True).wait_for_publish(10)
        conn.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(30) == 0
        assert (tmp_path / "broker" / "data" / "mosquitto.db").is_file()
        assert (tmp_path / "broker" / "credentials.json").stat().st_mode & 0o077 == 0

        proc, url2 = _run_broker_process(port, tmp_path / "broker")
        assert url2 == url  # same generated credentials
        got = []
        conn = MqttConnection(
            url, "forever-sub", subscriptions=[("keep/me", 1)], on_message=got.append
        )
        deadline = time.monotonic() + 20
        while not got and time.monotonic() < deadline:
            time.sleep(0.05)
        conn.close()
        assert [m.payload for m in got] == [b"42"]  # the retained message survived
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(30)


@pytest.mark.mqtt
def test_an_acl_confines_a_user_to_its_build_and_refusals_are_errors(tmp_path, make_sample):
    acl = tmp_path / "acl"
    acl.write_text("pattern readwrite datagen/%u/#\n")  # user "b1" may use build b1 only
    with ManagedBroker(BrokerSettings(username="b1", password="secret-1", acl_file=acl)) as b:
        with SamplePublisher(b.url, "b1", "acl-own") as pub:
            pub.publish(make_sample(0))  # allowed (no subscriber: published again a few times)
            pub.publish_timeout_s = 0.5
            with pytest.raises(PublishTimeout, match="no writer subscribed"):
                pub.flush()
        with SamplePublisher(b.url, "b2", "acl-other") as pub:
            pub.publish(make_sample(0))
            with pytest.raises(PublishRefused, match=r"refused sample 000000000 .*Not authorized"):
                pub.flush()


@pytest.mark.mqtt
def test_a_parent_death_signal_survives_mosquitto_dropping_root():
    """The coordinator passes a preexec_fn asking for SIGKILL when it dies (PR_SET_PDEATHSIG);
    a process that changes its user loses that, so as root ManagedBroker starts mosquitto as
    user mosquitto itself. Here the parent is SIGKILLed and mosquitto must go with it."""
    code = (
        "import ctypes, signal, time\n"
        "from datagen.transport.mosquitto import ManagedBroker\n"
        "def die(): ctypes.CDLL('libc.so.6').prctl(1, signal.SIGKILL)\n"  # PR_SET_PDEATHSIG
        "b = ManagedBroker(preexec_fn=die)\n"
        "b.start()\n"
        "print(b.pid, b.dir, flush=True)\n"
        "time.sleep(120)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    pid, broker_dir = parent.stdout.readline().split()
    pid = int(pid)
    parent.kill()
    parent.wait()

    def alive() -> bool:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().split(") ", 1)[1][0]
        except (FileNotFoundError, ProcessLookupError):
            return False
        return state != "Z"  # a zombie is dead, waiting for init to reap it

    deadline = time.monotonic() + 20
    while alive() and time.monotonic() < deadline:
        time.sleep(0.05)
    survived = alive()
    if survived:
        os.kill(pid, signal.SIGKILL)
    shutil.rmtree(broker_dir, ignore_errors=True)
    assert not survived, "mosquitto outlived its parent"
