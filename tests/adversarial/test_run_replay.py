"""Every signed message is bound to the run that made it, not only to the build id: two runs that
share a build id and a secret (a script with fixed values) cannot be mixed. A client with the
broker's credentials records run A (samples, acks, control) and replays all of it into run B,
before B's writer is bound and while B runs: B's writer and coordinator drop and count every
message of A, and B ends with exactly its own N samples (its seed), verified. A writer started
before its run is bound only by a bind that echoes its own challenge, and every client id is
unguessable (no other broker user can take a session over)."""

from __future__ import annotations

import json
import re
import secrets
import threading
import time

import paho.mqtt.client as mqtt
import pytest

from datagen.config import config_from_dict
from datagen.dataset.loader import load, verify
from datagen.pipeline.run import run_build
from datagen.sample import Sample
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.collector import AckCollector
from datagen.transport.publisher import SamplePublisher
from datagen.transport.run_binding import RunBinding, client_id, writer_client_id
from datagen.transport.topics import topics
from datagen.transport.wire import SECRET_ENV

pytestmark = [pytest.mark.adversarial]
N = 3


def tiny_config(seed: int):
    return config_from_dict({
        "num_samples": N, "seed": seed,
        "render": {"width": 64, "height": 48, "wrist_camera": False},
        "objects": {"count": [1, 1]}, "physics": {"settle_time": 0.1},
        "output": {"shard_size": N, "formats": ["webdataset"]},
    })  # fmt: skip


class Replayer:
    """A paho client with the broker's credentials: records every message of a build (a plain,
    not shared, subscription gets a copy of each sample), then publishes the recording again,
    over and over, until stopped."""

    def __init__(self, url: str, build_id: str):
        self.t = topics(build_id)
        address = parse_broker_url(url)
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5)
        self.client.username_pw_set(address.username, address.password)
        self.recorded: list[tuple[str, bytes]] = []
        self.client.on_message = lambda c, u, m: self.recorded.append((m.topic, m.payload))
        self.client.connect(address.host, address.port)
        self.client.loop_start()
        self.client.subscribe(f"datagen/{build_id}/#", qos=1)
        self.stop = threading.Event()
        self.sent = 0

    def of(self, topic: str) -> list[bytes]:
        return [payload for t, payload in self.recorded if t == topic]

    def replay_until_stopped(self) -> threading.Thread:
        self.client.unsubscribe(f"datagen/{self.t.build_id}/#")
        wanted = (self.t.samples, self.t.acks, self.t.control)
        replay = [(topic, p) for topic, p in self.recorded if topic in wanted and p]

        def loop() -> None:
            while not self.stop.is_set():
                for topic, payload in replay:
                    self.client.publish(topic, payload, qos=1)
                    self.sent += 1
                self.stop.wait(0.3)

        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        return thread

    def close(self) -> None:
        self.stop.set()
        self.client.loop_stop()
        self.client.disconnect()


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_a_replayed_run_changes_nothing_in_another_run_of_the_same_build_id_and_secret(
    tmp_path, broker, build_id, monkeypatch
):
    secret = secrets.token_bytes(32)
    monkeypatch.setenv(SECRET_ENV, secret.hex())  # both runs: fixed id and secret
    replayer = Replayer(broker.url, build_id)
    try:
        first = run_build(tiny_config(seed=11), tmp_path / "a", 1, broker_url=broker.url,
                          build_id=build_id)  # fmt: skip
        assert first.samples == N
        t = replayer.t
        assert len(replayer.of(t.samples)) >= N and replayer.of(t.acks)
        assert any(b"finalize" in p for p in replayer.of(t.control))
        replaying = replayer.replay_until_stopped()  # before run B's writer exists, and during B
        log_before_b = broker.log_path.stat().st_size
        second = run_build(tiny_config(seed=12), tmp_path / "b", 1, broker_url=broker.url,
                           build_id=build_id)  # fmt: skip
    finally:
        replayer.close()
    replaying.join(5)
    assert replayer.sent > 3 * len(replayer.of(t.samples))
    manifest = verify(tmp_path / "b")  # every sample once, every digest intact
    assert manifest["samples"] == N and manifest["seed"] == 12
    dataset = load(tmp_path / "b")
    assert [dataset.metadata(i)["seed"] for i in range(N)] == [12] * N  # none of run A's
    assert second.restarts["writer"] == 0  # no crash loop on run A's finalize
    assert manifest["rejected_messages"] > 0  # run A's samples, dropped and counted
    assert manifest["rejected_control_messages"] > 0  # run A's control commands and acks
    # run A's acks, at the coordinator: of another run, or older than run A's retained status
    assert second.rejected.get("wrong_run", 0) + second.rejected.get("replayed", 0) > 0
    # every client of both runs had an unguessable id; none of run A's came back in run B but
    # the writer's (the same secret, build and writer id: its persistent session's)
    log = broker.log_path.read_bytes()
    ids = [re.findall(rf" as (datagen-{build_id}-\S+) \(", part.decode(errors="replace"))
           for part in (log[:log_before_b], log[log_before_b:])]  # fmt: skip
    assert ids[0] and ids[1]
    for found in ids[0] + ids[1]:
        assert re.fullmatch(rf"datagen-{build_id}-[a-z0-9-]+-[0-9a-f]{{16}}", found), found
    assert set(ids[0]) & set(ids[1]) == {writer_client_id(build_id, "0", secret)}


def test_client_ids_are_unguessable_and_new_every_run():
    first, again = client_id("b1", "acks"), client_id("b1", "acks")
    assert first != again and re.fullmatch(r"datagen-b1-acks-[0-9a-f]{16}", first)
    secret = bytes(range(32))
    writer = writer_client_id("b1", "A", secret)
    assert re.fullmatch(r"datagen-b1-writer-A-[0-9a-f]{16}", writer)
    assert writer == writer_client_id("b1", "A", secret)  # a restarted writer: same session
    assert writer not in {
        writer_client_id("b1", "A", bytes(32)),
        writer_client_id("b1", "B", secret),
    }
    assert writer_client_id("b1", "A", None) == "datagen-b1-writer-A"  # no secret: nothing hidden


def seeded(index: int, seed: int) -> Sample:
    return Sample(index, {"json": json.dumps({"index": index, "seed": seed}).encode()})


@pytest.mark.mqtt
def test_a_writer_started_before_its_run_is_bound_only_by_a_bind_that_echoes_its_challenge(
    broker, build_id, start_writer, tmp_path, monkeypatch
):
    secret = secrets.token_bytes(32)
    monkeypatch.setenv(SECRET_ENV, secret.hex())
    recorder = Replayer(broker.url, build_id)
    # run A, recorded: a writer bound by a coordinator's collector, samples of seed 1
    with AckCollector(broker.url, build_id, secret=secret, run=RunBinding.draw({}, 1)) as run_a:
        writer_a = start_writer(out=tmp_path / "a", writer_id="0", shard_size=3)
        run_a.wait_status("ready", writer="0", timeout_s=60)
        with SamplePublisher(broker.url, build_id, "pub-a", secret=secret, run=run_a.run) as pub:
            for i in range(3):
                pub.publish(seeded(i, seed=1))
        assert run_a.wait_acked(range(3), timeout_s=60), writer_a.log()
        assert run_a.announce(["0"], timeout_s=60) == 3
        assert run_a.finalize(3, {})["state"] == "finalized", writer_a.log()
    assert writer_a.wait() == 0
    a_logged = len(writer_a.log())
    # run B: a writer started before its coordinator, waiting, while run A is replayed at it
    replaying = recorder.replay_until_stopped()
    try:
        writer_b = start_writer(out=tmp_path / "b", writer_id="0", shard_size=3)
        time.sleep(2.0)  # run A's binds, announce, finalize, acks and samples reach it
        assert writer_b.proc.poll() is None and not (tmp_path / "b" / "manifest.json").exists()
        run = RunBinding.draw({}, 2)
        with AckCollector(broker.url, build_id, secret=secret, run=run) as run_b:
            run_b.wait_status("ready", writer="0", timeout_s=60)
            with SamplePublisher(broker.url, build_id, "pub-b", secret=secret, run=run) as pub:
                for i in range(3):
                    pub.publish(seeded(i, seed=2))
            assert run_b.wait_acked(range(3), timeout_s=60), writer_b.log()
            assert run_b.finalize(3, {})["state"] == "finalized", writer_b.log()[a_logged:]
    finally:
        recorder.close()
    replaying.join(5)
    assert writer_b.wait() == 0
    manifest = verify(tmp_path / "b")
    assert [load(tmp_path / "b").metadata(i)["seed"] for i in range(3)] == [2, 2, 2]
    logged = writer_b.log()[a_logged:]
    assert "refused a bind to run" in logged and "refused a command of run" in logged
    assert manifest["rejected_control_messages"] >= 2  # run A's bind, finalize, announce, acks
    assert manifest["rejected_messages"] >= 3  # run A's samples
