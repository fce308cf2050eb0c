"""Least privilege on a shared broker: the per-role ACL file and commands of docs/deployment.md
('Least privilege'), read from the doc and run as printed on a real Mosquitto. Each role may
publish only its own topics (a refused publish reaches nobody), and a build whose workers,
writer and coordinator each use their own user ends with exactly N verified samples."""

from __future__ import annotations

import os
import re
import secrets
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import paho.mqtt.client as mqtt
import pytest

from adversarial.leaks import ProcessWatcher, leaking_files, leaks, secret_forms
from datagen.dataset.loader import check_complete
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.publisher import PublishRefused, SamplePublisher
from datagen.transport.topics import topics

pytestmark = [pytest.mark.adversarial, pytest.mark.mqtt]
REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "deployment.md"
BUILD_ID = "grasp-0001"  # the build the doc's ACL file names
ROLES = ("coordinator", "writer", "worker")
T = topics(BUILD_ID)


def doc_block(tag: str) -> str:
    """The fenced block right after ``<!-- test: tag -->`` in docs/deployment.md."""
    found = re.search(
        rf"<!-- test: {re.escape(tag)} -->\n```\w*\n(.*?)\n```\n", DOC.read_text(), re.S
    )
    assert found, f"docs/deployment.md has no block tagged <!-- test: {tag} -->"
    return found[1] + "\n"


def doc_env(passwords: dict[str, str], **more: str) -> dict[str, str]:
    """What the doc's commands expect: ``datagen`` on PATH, the role passwords, ``more``."""
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])
    env = os.environ | {"PATH": path} | more
    return env | {f"{role.upper()}_PASSWORD": pw for role, pw in passwords.items()}


@pytest.fixture
def role_broker(tmp_path):
    """Mosquitto with the doc's ACL file and the users made by the doc's commands."""
    passwords = {role: secrets.token_hex(16) for role in ROLES}
    made = subprocess.run(["bash", "-euc", doc_block("acl-users")], cwd=tmp_path,
                          env=doc_env(passwords), capture_output=True, text=True)  # fmt: skip
    assert made.returncode == 0, made.stderr
    acl, users = tmp_path / "datagen.acl", tmp_path / "datagen.passwd"
    assert users.stat().st_mode & 0o777 == 0o600
    hashed = users.read_text()
    assert hashed.count("$7$") == 3 and not any(pw in hashed for pw in passwords.values())
    acl.write_text(doc_block("acl-roles"))
    with ManagedBroker(BrokerSettings(acl_file=acl, password_file=users)) as broker:
        yield broker, passwords


class Client:
    """A paho client of one role; records what it receives and each publish's PUBACK."""

    def __init__(self, broker, passwords, role, v5=True, will: str | None = None):
        protocol = mqtt.MQTTv5 if v5 else mqtt.MQTTv311
        self.c = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, protocol=protocol, reconnect_on_failure=False
        )
        self.c.username_pw_set(f"{BUILD_ID}-{role}", passwords[role])
        if will is not None:
            self.c.will_set(will, f"{role}'s will -> {will}".encode(), qos=1)
        self.received: list[tuple[str, bytes]] = []
        self.pubacks: dict[int, str] = {}
        self.c.on_message = lambda c, u, m: self.received.append((m.topic, m.payload))
        self.c.on_publish = lambda c, u, mid, rc, p: self.pubacks.__setitem__(mid, str(rc))
        connected = threading.Event()
        self.c.on_connect = lambda c, u, flags, rc, p: connected.set()
        self.c.connect("127.0.0.1", broker.port)
        self.c.loop_start()
        assert connected.wait(5), f"{role}: no CONNACK"

    def subscribe(self, *topics_: str) -> None:
        self.c.subscribe([(t, 1) for t in topics_])

    def publish(self, topic: str, payload: bytes) -> str:
        """The PUBACK's reason: 'Success', or 'Not authorized' (MQTT v5 only)."""
        info = self.c.publish(topic, payload, qos=1)
        info.wait_for_publish(5)
        deadline = time.monotonic() + 5
        while info.mid not in self.pubacks and time.monotonic() < deadline:
            time.sleep(0.01)
        return self.pubacks[info.mid]

    def vanish(self) -> None:
        """Drops the connection without a DISCONNECT, as a killed process: the will goes out."""
        self.c.socket().close()
        self.c.loop_stop()

    def close(self) -> None:
        self.c.loop_stop()
        self.c.disconnect()


def test_each_role_may_publish_only_its_own_topics(role_broker):
    broker, passwords = role_broker
    clients = {role: Client(broker, passwords, role) for role in ROLES}
    for role, client in clients.items():  # subscribing is granted: only delivery is checked
        samples = T.shared_samples if role == "writer" else T.samples
        client.subscribe(samples, T.acks, T.control, T.status_all)
    v311_worker = Client(broker, passwords, "worker", v5=False)
    time.sleep(0.5)
    may_publish = {
        "worker": {T.samples},
        "writer": {T.acks, T.status("A")},
        "coordinator": {T.control},
    }
    accepted = []
    for role, client in clients.items():
        for topic in (T.samples, T.acks, T.control, T.status("A")):
            payload = f"{role} -> {topic}".encode()
            reason = client.publish(topic, payload)
            assert reason == ("Success" if topic in may_publish[role] else "Not authorized"), (
                payload
            )
            if reason == "Success":
                accepted.append((topic, payload))
    # MQTT 3.1.1 has no reason codes: the broker acknowledges a refused publish, and drops it
    assert v311_worker.publish(T.control, b"v3.1.1 worker -> control") == "Success"
    # a will is a publish too: the writer's (its status) goes out, one on control does not
    for role, topic in (("writer", T.status("A")), ("worker", T.control)):
        Client(broker, passwords, role, will=topic).vanish()
    accepted.append((T.status("A"), b"writer's will -> " + T.status("A").encode()))
    time.sleep(1.0)
    may_read = {
        "worker": set(),
        "writer": {T.samples, T.acks, T.control, T.status("A")},
        "coordinator": {T.acks, T.status("A")},
    }
    for role, client in clients.items():
        delivered = {payload for _, payload in client.received}
        assert delivered == {p for topic, p in accepted if topic in may_read[role]}, role
    assert len(accepted) == 5  # the allowed ones; every refused one reached nobody
    for client in [*clients.values(), v311_worker]:
        client.close()


def test_a_sample_from_a_user_that_may_not_publish_samples_is_an_error(role_broker, make_sample):
    broker, passwords = role_broker
    url = f"mqtt://{BUILD_ID}-coordinator:{passwords['coordinator']}@127.0.0.1:{broker.port}"
    with SamplePublisher(url, BUILD_ID, "acl-not-a-worker") as publisher:
        publisher.publish(make_sample(0))
        with pytest.raises(PublishRefused, match=r"refused sample 000000000 .*Not authorized"):
            publisher.flush()


@pytest.mark.sim
@pytest.mark.slow
def test_a_build_under_the_role_acl_ends_with_exactly_n_verified_samples(tmp_path, role_broker):
    broker, passwords = role_broker
    out, secret = tmp_path / "ds", secrets.token_bytes(32)
    env = doc_env(passwords, BROKER=f"127.0.0.1:{broker.port}", DIR=str(out), SECRET=secret.hex())
    watcher = ProcessWatcher()
    with open(tmp_path / "writer.log", "wb") as log:
        writer = subprocess.Popen(["bash", "-euc", doc_block("acl-writer")], cwd=REPO, env=env,
                                  stdout=log, stderr=log, stdin=subprocess.DEVNULL,
                                  start_new_session=True)  # fmt: skip
    try:
        built = subprocess.run(["bash", "-euc", doc_block("acl-build")], cwd=REPO, env=env,
                               capture_output=True, text=True, timeout=600)  # fmt: skip
        assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-3000:]
        assert writer.wait(60) == 0, (tmp_path / "writer.log").read_text()[-3000:]
    finally:
        watcher.stop()
        if writer.poll() is None:
            os.killpg(writer.pid, signal.SIGKILL)
            writer.wait()
    manifest = check_complete(out, 4, BUILD_ID)
    assert manifest["rejected_control_messages"] == 0
    # each role connected as its own user, with an unguessable client id (16 hex digits)
    connected = broker.log_path.read_text()
    for client_id, role in [
        (f"datagen-{BUILD_ID}-acks", "coordinator"),
        (f"datagen-{BUILD_ID}-writer-A", "writer"),
        (f"datagen-{BUILD_ID}-worker-0", "worker"),
    ]:
        unguessable = rf"{re.escape(client_id)}-[0-9a-f]{{16}}"
        assert re.search(rf"as {unguessable} \(.*u'{BUILD_ID}-{role}'\)", connected), role
    # and no password or secret showed up anywhere
    forms = secret_forms([*passwords.values()], secret)
    printed = built.stdout + built.stderr + (tmp_path / "writer.log").read_text()
    assert leaks(printed, forms) == [] and leaking_files(out, forms) == {}
    assert watcher.leaking(forms) == {}
