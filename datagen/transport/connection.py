"""The one way datagen opens an MQTT v5 connection (publishers, ack collector, writers).

``MqttConnection`` connects with username/password from the broker URL (TLS for ``mqtts://``,
verifying the broker's certificate and host name), runs paho's network thread, (re)subscribes
on every connect, and returns only once connected and subscribed. Failures say what went wrong:
``cannot reach broker host:port``, ``TLS verification failed for host:port``, ``broker refused
the credentials``.

The CA file for ``mqtts://`` is the ``ca_file`` argument, else ``$DATAGEN_MQTT_CA_FILE``, else
the system's trust store. This is the only place datagen reads that variable, so every process
(workers included) finds the same CA without passing it through every layer.

``broker_answers`` is a one-shot probe: does an MQTT broker answer on host:port yet?
"""

from __future__ import annotations

import json
import logging
import os
import ssl
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import paho.mqtt.client as mqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from paho.mqtt.subscribeoptions import SubscribeOptions

from datagen.errors import DatagenError
from datagen.transport.broker_url import parse_broker_url

log = logging.getLogger(__name__)

KEEPALIVE_S = 30
CA_FILE_ENV = "DATAGEN_MQTT_CA_FILE"
# CONNACK reason codes that mean "who you are" was rejected
_CREDENTIAL_CODES = {134, 135}  # Bad user name or password, Not authorized


def _drop_not_connected(record: logging.LogRecord) -> bool:
    # paho 2.2 logs "Client is not connected" at ERROR on every loop pass while (re)connecting
    # and once after a clean disconnect; the on_connect/on_disconnect logs below say it better.
    return not str(record.msg).startswith("Client is not connected")


_paho_log = logging.getLogger("paho")
_paho_log.addFilter(_drop_not_connected)

Subscription = tuple[str, int | SubscribeOptions]


class MqttConnectError(DatagenError, ConnectionError):
    """The broker refused us, or could not be reached in time."""


class MqttConnection:
    """A connected paho client (MQTT v5, network loop in a background thread).

    ``session_expiry_s > 0`` makes the session persistent (clean_start=False): the broker keeps
    subscriptions and queued QoS 1 messages while we are away, for that long
    (docs/mqtt-pitfalls.md, pitfall 5).
    ``subscriptions`` are ``(topic, qos)`` or ``(topic, SubscribeOptions)``.
    ``on_connected()`` runs on paho's thread after every (re)connect, once subscribed.
    """

    def __init__(
        self,
        broker_url: str,
        client_id: str,
        *,
        subscriptions: Sequence[Subscription] = (),
        on_message: Callable[[mqtt.MQTTMessage], None] | None = None,
        manual_ack: bool = False,
        session_expiry_s: int = 0,
        receive_maximum: int | None = None,
        will: tuple[str, bytes, int, bool] | None = None,
        timeout_s: float = 10.0,
        ca_file: str | os.PathLike | None = None,
        on_connected: Callable[[], None] | None = None,
    ):
        addr = parse_broker_url(broker_url)
        self.client_id = client_id
        self.address = f"{addr.host}:{addr.port}"
        self._username = addr.username
        self._subscriptions = list(subscriptions)
        self._on_message = on_message
        self._on_connected = on_connected
        self._ready = threading.Event()
        self._failure: str | None = None
        self._pending_sub_mid: int | None = None
        self._unsubacks: set[int] = set()
        self._unsub_cond = threading.Condition()
        self.callback_errors = 0  # exceptions our callbacks raised on paho's thread

        c = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2,
            client_id=client_id,
            protocol=mqtt.MQTTv5,
            manual_ack=manual_ack,
        )
        c.enable_logger(_paho_log)
        if addr.username is not None:
            c.username_pw_set(addr.username, addr.password)
        ca = None
        if addr.tls:
            ca = os.fspath(ca_file) if ca_file is not None else os.environ.get(CA_FILE_ENV) or None
            if ca is not None and not os.path.isfile(ca):
                raise MqttConnectError(f"CA file {ca} for {self.address} does not exist")
            # PROTOCOL_TLS_CLIENT: certificate required and host name checked
            c.tls_set(ca_certs=ca)
        if will is not None:
            topic, payload, qos, retain = will
            c.will_set(topic, payload, qos=qos, retain=retain)
        c.reconnect_delay_set(min_delay=1, max_delay=5)
        c.connect_timeout = max(0.5, min(5.0, timeout_s))
        c.on_connect = self.guarded(self._handle_connect)
        c.on_subscribe = self.guarded(self._handle_subscribe)
        c.on_unsubscribe = self.guarded(self._handle_unsubscribe)
        c.on_disconnect = self.guarded(self._handle_disconnect)
        c.on_message = self.guarded(self._handle_message)
        props = Properties(PacketTypes.CONNECT)
        props.SessionExpiryInterval = session_expiry_s
        if receive_maximum is not None:
            props.ReceiveMaximum = receive_maximum
        self.client = c

        # The first connection is made here, not in paho's thread, to see why it fails; paho's
        # thread reconnects after that.
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                c.connect(
                    addr.host,
                    addr.port,
                    KEEPALIVE_S,
                    clean_start=session_expiry_s == 0,
                    properties=props,
                )
                break
            except ssl.SSLCertVerificationError as exc:
                raise MqttConnectError(
                    f"TLS verification failed for {self.address}: "
                    f"{exc.verify_message or exc} (CA file: {ca or 'the system trust store'})"
                ) from None
            except ssl.SSLError as exc:
                raise MqttConnectError(
                    f"TLS handshake with {self.address} failed ({exc.reason or exc}); "
                    f"is that port a TLS listener?"
                ) from None
            except OSError as exc:
                if time.monotonic() >= deadline:
                    hint = ""
                    if addr.tls and isinstance(exc, ConnectionResetError):
                        hint = " (is that port a TLS listener?)"
                    raise MqttConnectError(
                        f"cannot reach broker {self.address} within {timeout_s} s: {exc}{hint}"
                    ) from None
                time.sleep(min(0.5, max(0.0, deadline - time.monotonic())))
        c.loop_start()
        if not self._ready.wait(max(0.0, deadline - time.monotonic()) + 1.0) or self._failure:
            c.disconnect()
            c.loop_stop()
            why = self._failure or f"no CONNACK within {timeout_s} s"
            raise MqttConnectError(f"MQTT {client_id!r} -> {self.address}: {why}")

    def guarded(self, callback: Callable[..., None]) -> Callable[..., None]:
        """``callback``, for paho: an exception it raises would end paho's network thread (no
        message, no reconnect ever after); it is logged and counted in ``callback_errors``."""

        def run(*args: Any) -> None:
            try:
                callback(*args)
            except Exception:
                self.callback_errors += 1  # paho calls back on its one network thread
                log.exception("MQTT %s: %s failed; going on", self.client_id, callback.__name__)

        return run

    def publish_json(
        self, topic: str, obj: Any, qos: int = 1, retain: bool = False
    ) -> mqtt.MQTTMessageInfo:
        payload = json.dumps(obj, separators=(",", ":")).encode("utf-8")
        return self.client.publish(topic, payload, qos=qos, retain=retain)

    def publish(
        self, topic: str, payload: bytes, qos: int = 1, retain: bool = False
    ) -> mqtt.MQTTMessageInfo:
        return self.client.publish(topic, payload, qos=qos, retain=retain)

    def unsubscribe(self, topic: str, timeout_s: float = 10.0) -> bool:
        """Drops ``topic`` (also from the re-subscriptions after a reconnect); True once the
        broker confirmed it."""
        self._subscriptions = [s for s in self._subscriptions if s[0] != topic]
        rc, mid = self.client.unsubscribe(topic)
        if rc != mqtt.MQTT_ERR_SUCCESS or mid is None:
            return False
        with self._unsub_cond:
            return self._unsub_cond.wait_for(lambda: mid in self._unsubacks, timeout_s)

    def close(self, end_session: bool = False) -> None:
        """Disconnects cleanly (no will); ``end_session`` tells the broker to drop our session."""
        props = None
        if end_session:
            props = Properties(PacketTypes.DISCONNECT)
            props.SessionExpiryInterval = 0
        self.client.disconnect(properties=props)
        self.client.loop_stop()

    def _refusal(self, reason_code) -> str:
        if reason_code.value in _CREDENTIAL_CODES:
            who = f"user {self._username!r}" if self._username else "no username given"
            return f"broker refused the credentials ({who}) at {self.address}: {reason_code}"
        return f"broker {self.address} refused the connection: {reason_code}"

    def _handle_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._failure = self._refusal(reason_code)
            log.error("MQTT %s: %s", self.client_id, self._failure)
            client.disconnect()
            self._ready.set()
            return
        log.info("MQTT %s connected (session present: %s)", self.client_id, flags.session_present)
        if not self._subscriptions:
            self._connected()
            return
        subs = [
            (topic, opts if isinstance(opts, SubscribeOptions) else SubscribeOptions(qos=opts))
            for topic, opts in self._subscriptions
        ]
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
            return
        self._connected()

    def _connected(self) -> None:
        self._ready.set()
        if self._on_connected is not None:
            self._on_connected()

    def _handle_unsubscribe(self, client, userdata, mid, reason_codes, properties) -> None:
        with self._unsub_cond:
            self._unsubacks.add(mid)
            self._unsub_cond.notify_all()

    def _handle_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            log.warning("MQTT %s disconnected: %s; paho reconnects", self.client_id, reason_code)

    def _handle_message(self, client, userdata, message: mqtt.MQTTMessage) -> None:
        if self._on_message is not None:
            self._on_message(message)


def broker_answers(host: str, port: int, username: str, password: str, timeout_s: float) -> bool:
    """True as soon as an MQTT broker on host:port answers a CONNECT with a CONNACK, whatever
    its reason code (even a refusal proves a broker is there); False on a socket error or no
    answer within ``timeout_s``. Polled while a broker starts, so keep ``timeout_s`` short."""
    answered = threading.Event()

    def on_connect(client, userdata, flags, reason_code, properties) -> None:
        answered.set()

    # No reconnecting: the network thread ends when the broker closes the connection.
    client = mqtt.Client(
        mqtt.CallbackAPIVersion.VERSION2, protocol=mqtt.MQTTv5, reconnect_on_failure=False
    )
    client.username_pw_set(username, password)
    client.connect_timeout = timeout_s
    client.on_connect = on_connect
    deadline = time.monotonic() + timeout_s
    try:
        client.connect(host, port, keepalive=10)
        client.loop_start()
        return answered.wait(max(0.0, deadline - time.monotonic()))
    except OSError:
        return False
    finally:
        client.disconnect()
        client.loop_stop()
