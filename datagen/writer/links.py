"""A writer's MQTT connections: one to the build's broker, and a second one to its own sample
broker when the build spreads samples over several (``datagen writer --sample-broker``,
:mod:`datagen.transport.sample_routes`). Commands, acks and statuses always use the first."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import paho.mqtt.client as mqtt
from paho.mqtt.subscribeoptions import SubscribeOptions

from datagen.transport.connection import MqttConnection
from datagen.transport.topics import Topics


@dataclass
class WriterLinks:
    control: MqttConnection  # commands, acks, statuses (and the samples, with one broker)
    samples: MqttConnection  # ``control`` itself, or the connection to the sample broker
    topics: Topics

    @classmethod
    def connect(
        cls,
        broker_url: str,
        sample_url: str | None,
        client_id: str,
        topics: Topics,
        *,
        on_message: Callable[[mqtt.MQTTMessage], None],
        on_sample: Callable[[mqtt.MQTTMessage], None],
        session_expiry_s: int,
        receive_maximum: int,
        will: tuple[str, bytes, int, bool],
        ca_file: str | None,
        on_connected: Callable[[], None],
    ) -> WriterLinks:
        """Persistent sessions (manual MQTT acks, ``receive_maximum`` messages in flight) to
        ``broker_url`` and, if given, ``sample_url`` (client id ``CLIENT_ID-samples``)."""
        samples = [(topics.shared_samples, 1)]
        # both: persistent sessions, MQTT acks by hand, the same receive window
        session = functools.partial(
            MqttConnection,
            manual_ack=True,
            session_expiry_s=session_expiry_s,
            receive_maximum=receive_maximum,
            ca_file=ca_file,
        )
        control = session(
            broker_url,
            client_id,
            subscriptions=[
                *(samples if sample_url is None else []),
                (topics.control, 1),
                # QoS 0: never held back by the receive window full of samples, never queued
                (topics.acks, SubscribeOptions(qos=0, noLocal=True)),
                (topics.status_all, SubscribeOptions(qos=0)),
            ],
            on_message=on_message,
            will=will,
            on_connected=on_connected,
        )
        if sample_url is None:
            return cls(control, control, topics)
        try:
            sample_conn = session(
                sample_url,
                f"{client_id}-samples",
                subscriptions=samples,
                on_message=on_sample,
            )
        except BaseException:
            control.close()
            raise
        return cls(control, sample_conn, topics)

    def ack(self, msg: mqtt.MQTTMessage) -> None:
        """MQTT-acknowledges ``msg`` on the connection it came on."""
        conn = self.samples if msg.topic == self.topics.samples else self.control
        conn.client.ack(msg.mid, msg.qos)

    def close(self, end_session: bool = False) -> None:
        if self.samples is not self.control:
            self.samples.close(end_session=end_session)
        self.control.close(end_session=end_session)
