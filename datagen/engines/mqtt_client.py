"""The one way datagen opens an MQTT v5 connection (publishers, ack collector, writers).

``MqttConnection`` connects with username/password from the broker URL, runs paho's network
thread, (re)subscribes on every connect, and returns only once connected and subscribed.
"""

from __future__ import annotations

import json
import logging
import ssl
import threading
from collections.abc import Callable, Sequence
from typing import Any

import paho.mqtt.client as mqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from paho.mqtt.subscribeoptions import SubscribeOptions

from datagen.engines.broker import parse_broker_url

log = logging.getLogger(__name__)

KEEPALIVE_S = 30


def _drop_not_connected(record: logging.LogRecord) -> bool:
    # paho 2.2 logs "Client is not connected" at ERROR on every loop pass while (re)connecting
    # and once after a clean disconnect; the on_connect/on_disconnect logs below say it better.
    return not str(record.msg).startswith("Client is not connected")


_paho_log = logging.getLogger("paho")
_paho_log.addFilter(_drop_not_connected)


class MqttConnectError(ConnectionError):
    """The broker refused us, or could not be reached in time."""


class MqttConnection:
    """A connected paho client (MQTT v5, network loop in a background thread).

    ``session_expiry_s > 0`` makes the session persistent (clean_start=False): the broker keeps
    subscriptions and queued QoS 1 messages while we are away (pitfall 5).
    """

    def __init__(
        self,
        broker_url: str,
        client_id: str,
        *,
        subscriptions: Sequence[tuple[str, int]] = (),
        on_message: Callable[[mqtt.MQTTMessage], None] | None = None,
        manual_ack: bool = False,
        session_expiry_s: int = 0,
        receive_maximum: int | None = None,
        will: tuple[str, bytes, int, bool] | None = None,
        timeout_s: float = 10.0,
    ):
        addr = parse_broker_url(broker_url)
        self.client_id = client_id
        self._subscriptions = list(subscriptions)
        self._on_message = on_message
        self._ready = threading.Event()
        self._failure: str | None = None
        self._pending_sub_mid: int | None = None

        c = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2,
            client_id=client_id,
            protocol=mqtt.MQTTv5,
            manual_ack=manual_ack,
        )
        c.enable_logger(_paho_log)
        if addr.username is not None:
            c.username_pw_set(addr.username, addr.password)
        if addr.tls:
            c.tls_set(cert_reqs=ssl.CERT_REQUIRED)
        if will is not None:
            topic, payload, qos, retain = will
            c.will_set(topic, payload, qos=qos, retain=retain)
        c.reconnect_delay_set(min_delay=1, max_delay=5)
        c.on_connect = self._handle_connect
        c.on_subscribe = self._handle_subscribe
        c.on_disconnect = self._handle_disconnect
        c.on_message = self._handle_message
        props = Properties(PacketTypes.CONNECT)
        props.SessionExpiryInterval = session_expiry_s
        if receive_maximum is not None:
            props.ReceiveMaximum = receive_maximum
        self.client = c

        c.connect_async(
            addr.host, addr.port, KEEPALIVE_S, clean_start=session_expiry_s == 0, properties=props
        )
        c.loop_start()
        if not self._ready.wait(timeout_s) or self._failure is not None:
            c.loop_stop()
            why = self._failure or f"no connection within {timeout_s} s"
            raise MqttConnectError(f"MQTT {client_id!r} -> {addr.host}:{addr.port}: {why}")

    def publish_json(
        self, topic: str, obj: Any, qos: int = 1, retain: bool = False
    ) -> mqtt.MQTTMessageInfo:
        payload = json.dumps(obj, separators=(",", ":")).encode("utf-8")
        return self.client.publish(topic, payload, qos=qos, retain=retain)

    def close(self, end_session: bool = False) -> None:
        """Disconnects cleanly (no will); ``end_session`` tells the broker to drop our session."""
        props = None
        if end_session:
            props = Properties(PacketTypes.DISCONNECT)
            props.SessionExpiryInterval = 0
        self.client.disconnect(properties=props)
        self.client.loop_stop()

    def _handle_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._failure = f"connection refused: {reason_code}"
            log.error("MQTT %s: %s", self.client_id, self._failure)
            client.disconnect()
            self._ready.set()
            return
        log.info("MQTT %s connected (session present: %s)", self.client_id, flags.session_present)
        if not self._subscriptions:
            self._ready.set()
            return
        subs = [(topic, SubscribeOptions(qos=qos)) for topic, qos in self._subscriptions]
        _, self._pending_sub_mid = client.subscribe(subs)

    def _handle_subscribe(self, client, userdata, mid, reason_codes, properties) -> None:
        if mid != self._pending_sub_mid:
            return
        failed = [
            f"{topic}: {rc}"
            for (topic, _), rc in zip(self._subscriptions, reason_codes, strict=False)
            if rc.is_failure
        ]
        if failed:
            self._failure = "subscription refused: " + "; ".join(failed)
            log.error("MQTT %s: %s", self.client_id, self._failure)
        self._ready.set()

    def _handle_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            log.warning("MQTT %s disconnected: %s; paho reconnects", self.client_id, reason_code)

    def _handle_message(self, client, userdata, message: mqtt.MQTTMessage) -> None:
        if self._on_message is not None:
            self._on_message(message)
