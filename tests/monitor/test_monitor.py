"""The live monitor (docs/monitor.md): the managed broker's WebSockets listener speaks MQTT, and
a real build with ``--monitor`` watched by headless Chromium (Debian's, driven by Playwright)
reaches "finished" with the right count and previews on the page."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import paho.mqtt.client as mqtt
import pytest

from datagen.monitor.server import PageConfig, page_config
from datagen.pipeline.live_preview import sample_outcome, thumbnail
from datagen.pipeline.live_status import campaign_summary
from datagen.sample import Sample
from datagen.transport.broker_settings import BrokerSettings
from datagen.transport.connection import MqttConnection
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.topics import LIVE_STATUS_ALL_BUILDS, topics

REPO = Path(__file__).resolve().parents[2]
DEPLOYMENT = REPO / "docs" / "deployment.md"
CHROMIUM = "/usr/bin/chromium"  # Debian's (scripts/install.sh); Playwright downloads none
SCREENSHOT_ENV = "DATAGEN_MONITOR_SCREENSHOT"  # a path: also save the screenshot there


def doc_block(doc: Path, tag: str) -> str:
    """The ```bash block right after ``<!-- test: tag -->`` in ``doc``: run as printed."""
    found = re.search(rf"<!-- test: {re.escape(tag)} -->\n```bash\n(.*?)\n```", doc.read_text(), re.S)  # fmt: skip
    assert found, f"{doc.name} has no command block tagged <!-- test: {tag} -->"
    return found[1]


# --- pure functions ------------------------------------------------------------------------------


def test_page_config_takes_a_websockets_url_apart_and_refuses_an_mqtt_one():
    config = page_config("ws://mon:p%40ss@broker.example.org:9001/mqtt", "grasp-0001")
    assert config == PageConfig("ws://broker.example.org:9001/mqtt", "mon", "p@ss", "grasp-0001")
    assert page_config(None, None) == PageConfig()
    with pytest.raises(ValueError, match=r"expected a WebSockets URL") as refused:
        page_config("mqtt://mon:hunter2@host:1883", None)
    assert "hunter2" not in str(refused.value)
    with pytest.raises(ValueError, match=r"ws\[s\]://host:port"):
        page_config("wss://host", None)


def test_campaign_summary_counts_each_sample_once_per_sampler_family_and_failure_mode():
    outcomes = {
        0: {"kind": "grasp", "success": True, "sampler": "antipodal", "family": "box",
            "failure_mode": None},
        1: {"kind": "grasp", "success": False, "sampler": "antipodal", "family": "mug",
            "failure_mode": "slipped"},
        2: {"kind": "grasp", "success": False, "sampler": "top_down", "family": "box",
            "failure_mode": "missed"},
    }  # fmt: skip
    outcomes[2] = outcomes[2] | {"success": True}  # a re-issued sample replaces its outcome
    summary = campaign_summary(outcomes.values())
    assert summary["campaign"]["attempts"] == 3
    assert summary["campaign"]["success_rate"] == round(2 / 3, 4)
    assert summary["campaign"]["per_sampler"]["antipodal"] == {
        "attempts": 2, "successes": 1, "success_rate": 0.5}  # fmt: skip
    assert summary["campaign"]["per_family"]["box"] == {
        "attempts": 2, "successes": 2, "success_rate": 1.0}  # fmt: skip
    assert summary["campaign"]["failure_modes"] == {"slipped": 1}
    nav = campaign_summary([{"kind": "navigation", "success": True, "spl": 0.8},
                            {"kind": "navigation", "success": False, "spl": 0.0}])  # fmt: skip
    assert nav == {"navigation": {"episodes": 2, "success_rate": 0.5, "spl": 0.4}}
    assert campaign_summary([]) == {}


def _png(image) -> bytes:
    return cv2.imencode(".png", image)[1].tobytes()


def test_a_preview_is_the_image_with_masks_and_boxes_at_thumbnail_size_or_the_episode_map():
    rgb = np.full((48, 64, 3), 40, np.uint8)
    seg = np.zeros((48, 64), np.uint16)
    seg[8:24, 16:40] = 7
    obj = {"instance_id": 7, "class": "box", "bbox_xyxy": [16, 8, 39, 23], "visible": True,
           "visible_fraction": 1.0}  # fmt: skip
    meta = {"format": "datagen.sample/1", "attempt": {"sampler": "antipodal", "target": {"class": "box"},
            "outcome": {"success": False, "failure_mode": "slipped"}},
            "views": {"workspace": {"objects": [obj], "camera": {}}}}  # fmt: skip
    sample = Sample(5, {"rgb.png": _png(rgb), "seg.png": _png(seg), "json": json.dumps(meta).encode()})  # fmt: skip
    thumb = thumbnail(sample, width=128)
    assert thumb.shape == (96, 128, 3)
    assert (thumb[4, 4] == 40).all()  # background untouched
    assert (thumb[16, 64] == 255).all()  # the box's top edge, scaled x2
    assert not (thumb[30, 60] == 40).all()  # the mask blended in
    assert sample_outcome(sample) == {"index": 5, "kind": "grasp", "success": False,
        "sampler": "antipodal", "family": "box", "failure_mode": "slipped"}  # fmt: skip
    world = np.zeros((30, 40, 3), np.uint8)
    world[:, :20] = (255, 0, 0)  # RGB red on the left
    episode = {"format": "datagen.nav_episode/1", "episode": {"success": True, "spl": 0.75}}
    nav = Sample(2, {"map.png": _png(world[..., ::-1]), "json": json.dumps(episode).encode()})
    drawn = thumbnail(nav, width=80)
    assert drawn.shape == (60, 80, 3) and tuple(drawn[30, 10]) == (0, 0, 255)  # BGR red
    assert sample_outcome(nav) == {"index": 2, "kind": "navigation", "success": True, "spl": 0.75}
    assert sample_outcome(Sample(1, {"json": b"{}"})) is None


# --- the command ------------------------------------------------------------------------------------


def datagen(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "datagen.cli", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)  # fmt: skip


def test_the_printed_monitor_command_serves_the_page_its_client_and_where_to_connect():
    """docs/deployment.md's ``datagen monitor`` for an external broker, run as printed: the
    page, mqtt.js and a config.json naming the broker (without the password in the URL), the
    monitor user and the build; Ctrl-C ends it with status 0."""
    command = doc_block(DEPLOYMENT, "monitor-external")
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])
    env = os.environ | {"PATH": path, "MONITOR_PASSWORD": "s3cret"}
    server = subprocess.Popen(["bash", "-euc", command], cwd=REPO, env=env, text=True,
                              stdout=subprocess.PIPE, start_new_session=True)  # fmt: skip
    try:
        line = server.stdout.readline()
        assert line == "datagen: monitor for wss://broker.example.org:8884: open http://127.0.0.1:8765/  (Ctrl-C stops it)\n"  # fmt: skip
        url = "http://127.0.0.1:8765/"
        with urllib.request.urlopen(url + "config.json", timeout=10) as answer:
            assert json.load(answer) == {"broker": "wss://broker.example.org:8884", "username": "datagen-monitor",
                                         "password": "s3cret", "build_id": "grasp-0001"}  # fmt: skip
        with urllib.request.urlopen(url, timeout=10) as answer:
            page = answer.read().decode()
        assert '<script src="vendor/mqtt.min.js"></script>' in page and "app.js" in page
        with urllib.request.urlopen(url + "vendor/mqtt.min.js", timeout=10) as answer:
            assert b"mqtt" in answer.read(2000)
        os.killpg(server.pid, signal.SIGINT)
        assert server.wait(10) == 0
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGKILL)
            server.wait()


def test_monitor_mistakes_are_one_line_and_exit_2(tmp_path):
    mqtt_url = datagen("monitor", "--broker", "mqtt://u:hunter2@host:1883")
    assert mqtt_url.returncode == 2 and "hunter2" not in mqtt_url.stderr
    assert mqtt_url.stderr.count("\n") == 1 and "expected a WebSockets URL" in mqtt_url.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        busy = datagen("monitor", "--port", str(taken.getsockname()[1]))
    assert busy.returncode == 2 and busy.stderr.count("\n") == 1, busy.stderr
    assert "choose another port, or --port 0" in busy.stderr
    external = datagen("build", "configs/grasp_tabletop.yaml", "--out", str(tmp_path / "ds"),
                       "--broker", "mqtt://u:p@127.0.0.1:1883", "--monitor")  # fmt: skip
    assert external.returncode == 2 and external.stderr.count("\n") == 1, external.stderr
    assert "datagen monitor --broker ws://HOST:PORT" in external.stderr


# --- the broker's WebSockets listener ------------------------------------------------------------


@pytest.mark.mqtt
def test_the_websockets_listener_serves_mqtt_to_the_monitor_account():
    """A real MQTT-over-WebSockets client (paho, transport="websockets") logs in as the monitor,
    finds the build through the retained status and receives its next status and preview."""
    t = topics("ws-check")
    with ManagedBroker(BrokerSettings(websockets=True)) as broker:
        assert broker.websockets_url == f"ws://127.0.0.1:{broker.websockets_port}"
        publisher = MqttConnection(broker.url, "coordinator")
        publisher.publish_json(t.live_status, {"state": "running"}, retain=True).wait_for_publish(5)
        received: list[mqtt.MQTTMessage] = []
        got = threading.Event()

        def on_message(client, userdata, message):
            received.append(message)
            got.set()

        client = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5, transport="websockets"
        )
        client.username_pw_set(broker.monitor_username, broker.monitor_password)
        client.on_message = on_message
        client.connect("127.0.0.1", broker.websockets_port)
        client.loop_start()
        try:
            client.subscribe([(LIVE_STATUS_ALL_BUILDS, 0), (t.live_preview_all, 0)])
            assert got.wait(10), "no retained status over WebSockets"
            publisher.publish(t.live_preview("0"), b"\xff\xd8jpeg", qos=0)
            publisher.publish_json(t.live_status, {"state": "finished"}, retain=True)
            deadline = time.monotonic() + 10
            while len(received) < 3 and time.monotonic() < deadline:
                time.sleep(0.05)
        finally:
            client.disconnect()
            client.loop_stop()
            publisher.close()
        seen = [(m.topic, m.payload, bool(m.retain)) for m in received]
        assert seen[0] == (t.live_status, b'{"state":"running"}', True)
        assert (t.live_preview("0"), b"\xff\xd8jpeg", False) in seen
        assert (t.live_status, b'{"state":"finished"}', False) in seen


# --- the status a build leaves on an external broker ----------------------------------------------


def retained_status(broker, build_id: str) -> bytes:
    """What a monitor subscribing after the build ended gets: exactly one retained status."""
    retained: list[mqtt.MQTTMessage] = []
    late = MqttConnection(
        broker.url, "late-monitor", subscriptions=[(topics(build_id).live_status, 0)],
        on_message=lambda m: retained.append(m),
    )  # fmt: skip
    deadline = time.monotonic() + 5
    while not retained and time.monotonic() < deadline:
        time.sleep(0.05)
    late.close()
    assert len(retained) == 1 and retained[0].retain
    return retained[0].payload


@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.mqtt
def test_a_finished_build_leaves_its_final_status_retained_for_a_late_monitor(broker, build_id, tmp_path):  # fmt: skip
    from datagen.config import config_from_dict
    from datagen.pipeline.run import run_build

    config = config_from_dict({
        "num_samples": 6, "seed": 3, "render": {"width": 64, "height": 48, "wrist_camera": False},
        "objects": {"count": [1, 2]}, "physics": {"settle_time": 0.2},
    })  # fmt: skip
    run_build(config, tmp_path / "ds", 2, broker_url=broker.url, build_id=build_id)
    payload = retained_status(broker, build_id)
    status = json.loads(payload)
    assert status["state"] == "finished" and status["message"] == "finished: 6/6 durable"
    assert (status["total"], status["durable"], status["published"]) == (6, 6, 6)
    assert status["restarts"] == {"worker": 0, "writer": 0, "broker": 0}
    assert status["history"][-1][1] == 6 and len(status["workers"]) == 2
    secret = json.loads((tmp_path / "ds" / "build.json").read_text())["secret"]
    assert secret not in payload.decode()


@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.mqtt
def test_a_failed_build_leaves_failed_and_why_retained_for_a_late_monitor(broker, build_id, tmp_path):  # fmt: skip
    """A real failure: every sample is larger than transfer.max_sample_mb, and the policy is
    to fail at the first failing sample."""
    from datagen.config import config_from_dict
    from datagen.errors import BuildError
    from datagen.pipeline.run import run_build

    config = config_from_dict({
        "num_samples": 4, "seed": 3, "render": {"width": 320, "height": 240},
        "objects": {"count": [1, 2]}, "physics": {"settle_time": 0.2},
        "transfer": {"max_sample_mb": 0.1}, "build": {"on_sample_error": "fail"},
    })  # fmt: skip
    with pytest.raises(BuildError):
        run_build(config, tmp_path / "ds", 1, broker_url=broker.url, build_id=build_id)
    payload = retained_status(broker, build_id)
    status = json.loads(payload)
    assert status["state"] == "failed", status
    assert status["message"].startswith("failed: ") and "max_sample_mb" in status["message"], status
    assert status["durable"] < status["total"] == 4


# --- a real build watched in a real browser ------------------------------------------------------


@pytest.mark.slow
@pytest.mark.sim
@pytest.mark.mqtt
@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian's chromium (scripts/install.sh)")
def test_the_printed_build_with_monitor_is_watched_to_the_end_in_headless_chromium(tmp_path):
    """docs/monitor.md's (and README's) command, as printed (in a directory holding the repository's
    configs/), and its URL opened in headless Chromium as soon as it is printed."""
    from playwright.sync_api import sync_playwright

    command = doc_block(REPO / "docs" / "monitor.md", "monitor-build")
    assert doc_block(REPO / "README.md", "monitor-build") == command  # README prints it too
    n = int(re.search(r"--num-samples (\d+)", command)[1])
    shutil.copytree(REPO / "configs", tmp_path / "configs")
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])
    env = os.environ | {"PATH": path, "PYTHONUNBUFFERED": "1"}
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        build = subprocess.Popen(["bash", "-euc", command], cwd=tmp_path, env=env, text=True,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT)  # fmt: skip
        try:
            lines = []
            for line in build.stdout:
                lines.append(line)
                if found := re.search(r"watch the build live: open (http://127\.0\.0\.1:\d+/)$", line.strip()):  # fmt: skip
                    break
            assert found, "".join(lines)
            page = browser.new_page(viewport={"width": 1200, "height": 800})
            page.goto(found[1])
            page.wait_for_selector('#state[data-state="finished"]', timeout=120_000)
            assert page.inner_text("#state") == f"finished: {n}/{n} durable"
            assert page.inner_text("#count") == f"{n} / {n}"
            shown = page.eval_on_selector_all("#previews img", "imgs => imgs.map(i => i.naturalWidth)")  # fmt: skip
            assert shown and all(w > 0 for w in shown), "no preview was displayed"
            assert page.locator("#workers tbody tr").count() >= 1
            page.screenshot(path=tmp_path / "monitor.png")
            if os.environ.get(SCREENSHOT_ENV):
                page.screenshot(path=os.environ[SCREENSHOT_ENV])
        finally:
            browser.close()
            rest, _ = build.communicate(timeout=120)
        assert build.returncode == 0, "".join(lines) + rest
        assert (tmp_path / "datasets" / "watch" / "manifest.json").is_file()
