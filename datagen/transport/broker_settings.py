"""What a Mosquitto for datagen is asked to be: its listeners, its limits, who may connect and
where it keeps its state, as one validated record (``ManagedBroker`` runs it; the
configuration file is written by ``mosquitto_config``). The limits' defaults and why they are
raised: docs/mqtt-pitfalls.md, pitfalls 1, 4 and 9."""

from __future__ import annotations

import os
from dataclasses import dataclass, fields
from pathlib import Path

from datagen.errors import DatagenError
from datagen.transport.wire import DEFAULT_MAX_MESSAGE_BYTES

PathLike = str | os.PathLike


class BrokerSettingsError(DatagenError, ValueError):
    """A broker setting out of its range."""


@dataclass(frozen=True)
class BrokerSettings:
    """One broker's settings. ``port`` (plain), ``tls_port`` and ``websockets_port`` of None
    are free ports chosen at start; ``data_dir`` None keeps everything in a temp dir removed at
    close; ``username``/``password`` None are generated (and, with a ``data_dir``, kept there).

    With ``tls_cert``/``tls_key`` (PEM files, copied into the broker's dir) a TLS listener
    serves ``host:tls_port``; the plain listener then binds to loopback only when ``host`` is
    not a loopback address, so passwords never cross the network in clear. ``acl_file``: a
    Mosquitto ACL file (copied), e.g. to confine users to their builds' topics.
    ``password_file``: more users (a ``mosquitto_passwd`` file, copied beside ours), e.g. one
    per role of a build (docs/deployment.md, 'Least privilege'). ``websockets``: a
    MQTT-over-WebSockets listener and a read-only ``monitor`` user for browsers."""

    # listeners
    host: str = "127.0.0.1"
    port: int | None = None
    advertise_host: str | None = None  # what other machines call it; default: host (or FQDN)
    tls_cert: Path | None = None
    tls_key: Path | None = None
    tls_port: int | None = None
    websockets: bool = False
    websockets_port: int | None = None
    websockets_host: str = "127.0.0.1"
    # limits
    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES
    max_queued_messages: int = 1_000_000
    max_queued_bytes: int = 2 * 2**30
    max_inflight_messages: int = 64
    autosave_interval_s: int = 2
    # access and state
    username: str | None = None
    password: str | None = None
    acl_file: Path | None = None
    password_file: Path | None = None
    data_dir: Path | None = None
    # the process
    executable: str = "mosquitto"
    startup_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        for name in ("tls_cert", "tls_key", "acl_file", "password_file", "data_dir"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, Path):
                object.__setattr__(self, name, Path(value))
        if (self.tls_cert is None) != (self.tls_key is None):
            raise BrokerSettingsError("broker settings: tls_cert and tls_key go together")
        for name in ("port", "tls_port", "websockets_port"):
            port = getattr(self, name)
            if port is not None and not 1 <= port <= 65535:
                raise BrokerSettingsError(
                    f"broker settings: {name} is {port}; expected 1-65535 or None"
                )
        for field in fields(self):
            value = getattr(self, field.name)
            limit = field.name.startswith("max_") or field.name.endswith("_s")
            if limit and not value > 0:
                raise BrokerSettingsError(f"broker settings: {field.name} is {value}; expected > 0")

    @property
    def tls(self) -> bool:
        return self.tls_cert is not None


def service_settings(
    *,
    host: str = "127.0.0.1",
    port: int = 1883,
    data_dir: PathLike | None = None,
    username: str | None = None,
    password: str | None = None,
    tls_cert: PathLike | None = None,
    tls_key: PathLike | None = None,
    advertise_host: str | None = None,
) -> BrokerSettings:
    """A long-lived broker's settings (``datagen broker``): ``port`` is the TLS port when
    ``tls_cert``/``tls_key`` are given (the plain listener then takes a free loopback port);
    its state is saved every 30 s."""
    tls = tls_cert is not None
    return BrokerSettings(
        host=host,
        port=None if tls else port,
        tls_port=port if tls else None,
        data_dir=Path(data_dir) if data_dir is not None else None,
        username=username,
        password=password,
        tls_cert=Path(tls_cert) if tls_cert is not None else None,
        tls_key=Path(tls_key) if tls_key is not None else None,
        advertise_host=advertise_host,
        autosave_interval_s=30,
    )
