"""A client with the broker's credentials but not the build secret cannot change a build's
outcome: forged, wrongly signed and replayed acks, status and control commands are dropped and
counted, and the build still ends with exactly N verified samples."""

from __future__ import annotations

import json
import secrets
import threading
import time

import paho.mqtt.client as mqtt
import pytest

from datagen.config import config_from_dict
from datagen.dataset.loader import check_complete
from datagen.pipeline.run import run_build
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.envelope import Sealer
from datagen.transport.topics import topics
from datagen.transport.wire import SECRET_ENV

pytestmark = [pytest.mark.adversarial]
SECRET = bytes(range(32))


class Attacker(threading.Thread):
    """Connects with the broker's credentials, records the build's genuine control-plane
    messages, and floods the build with forged ones and with replays of what it recorded."""

    def __init__(self, url: str, build_id: str):
        super().__init__(daemon=True)
        self.t = topics(build_id)
        address = parse_broker_url(url)
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5)
        self.client.username_pw_set(address.username, address.password)
        self.client.on_message = lambda c, u, m: self.recorded.append((m.topic, m.payload))
        self.client.connect(address.host, address.port)
        self.client.subscribe([(self.t.acks, 0), (self.t.control, 0), (self.t.status_all, 0)])
        self.client.loop_start()
        self.recorded: list[tuple[str, bytes]] = []
        self.stop = threading.Event()
        self.sent = 0

    def run(self) -> None:
        wrong = Sealer(b"\x02" * 32, self.t, "coordinator", "coordinator")
        while not self.stop.wait(0.05):
            forged = [
                (self.t.acks, {"indices": list(range(40)), "writer": "w1"}),
                (
                    self.t.control,
                    {
                        "cmd": "finalize",
                        "round": "x",
                        "samples": 3,
                        "manifest": {},
                        "writers": ["w1"],
                        "leader": "w1",
                    },
                ),
                (self.t.status("w1"), {"state": "finalized", "writer": "w1", "round": "x"}),
                (self.t.status("w1"), {"state": "ready", "writer": "w1"}),
            ]
            for topic, body in forged:
                self.client.publish(topic, json.dumps(body), qos=1)
                self.client.publish(topic, wrong.seal(topic, body), qos=1)
                self.sent += 2
            for topic, payload in list(self.recorded)[-20:]:  # replays of genuine messages
                self.client.publish(topic, payload, qos=1)
                self.sent += 1

    def close(self) -> None:
        self.stop.set()
        self.join(5)
        self.client.loop_stop()
        self.client.disconnect()


@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.slow
def test_forged_and_replayed_messages_do_not_change_the_outcome(
    tmp_path, broker, start_writer, build_id, monkeypatch
):
    monkeypatch.setenv(SECRET_ENV, secrets.token_hex(32))  # what an operator shares
    writer = start_writer(out=tmp_path / "ds", writer_id="w1", shard_size=5)
    attacker = Attacker(broker.url, build_id)
    attacker.start()
    config = config_from_dict({
        "num_samples": 16, "seed": 5,
        "render": {"width": 96, "height": 72, "wrist_camera": False},
        "objects": {"count": [1, 2]}, "physics": {"settle_time": 0.2},
    })  # fmt: skip
    try:
        time.sleep(1.0)  # forged status and acks are waiting before the build starts
        result = run_build(
            config, tmp_path / "ds", 2, broker_url=broker.url, writers=["w1"], build_id=build_id
        )
    finally:
        attacker.close()
    assert writer.wait(30) == 0, writer.log()
    assert result.samples == 16
    manifest = check_complete(tmp_path / "ds", 16, build_id)
    assert attacker.sent > 100 and attacker.recorded
    assert result.rejected.get("unsigned", 0) > 0 and result.rejected.get("bad_mac", 0) > 0
    assert manifest["rejected_control_messages"] > 0  # the writer dropped forged commands
