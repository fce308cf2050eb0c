"""The files a ``ManagedBroker`` gives Mosquitto: ``mosquitto.conf``, the password file, TLS and
ACL copies, owned by user ``mosquitto`` when started as root.

The configuration raises Mosquitto's queue limits (docs/mqtt-pitfalls.md, pitfall 1), sets a
maximum packet size that paho will not check for us (pitfall 4), and hands the broker's files
to user ``mosquitto``, which Mosquitto drops to when started as root (pitfall 9).
"""

from __future__ import annotations

import base64
import hashlib
import ipaddress
import logging
import os
import pwd
import secrets
import shutil
import stat
from pathlib import Path
from typing import Protocol

from datagen.transport.broker_settings import BrokerSettings

log = logging.getLogger(__name__)

# Room for the topic, properties and fixed header around the largest payload.
PACKET_OVERHEAD_BYTES = 64 * 1024
# With a WebSockets listener: the build's user may do anything, the monitor only read the live
# status and previews of every build (docs/monitor.md)
MONITOR_ACL = """
user {user}
topic readwrite #

user {monitor}
topic read datagen/+/live/#
"""


def websockets_listener(port: int, host: str) -> list[str]:
    """The lines of a WebSockets listener bound to ``host`` (an IP address, or ``localhost``)
    and nothing else. Mosquitto 2.0.21 hands the address to libwebsockets, which binds
    ``listener PORT 127.0.0.1`` on [::], every interface, unless ``socket_domain`` says the
    address's family, and binds nothing at all for a name (measured with ``ss -ltn``)."""
    try:
        address = ipaddress.ip_address({"localhost": "127.0.0.1", "": "0.0.0.0"}.get(host, host))
    except ValueError:
        raise ValueError(
            f"websockets_host {host!r}: expected an IP address (Mosquitto binds no WebSockets "
            f"listener to a name)"
        ) from None
    domain = "ipv4" if address.version == 4 else "ipv6"
    return [f"listener {port} {address}", "protocol websockets", f"socket_domain {domain}"]


def mosquitto_password_hash(password: str, iterations: int = 101) -> str:
    """Mosquitto 2.x ``$7$`` entry: PBKDF2-HMAC-SHA512, 12-byte salt, as mosquitto_passwd writes."""
    salt = secrets.token_bytes(12)
    digest = hashlib.pbkdf2_hmac("sha512", password.encode("utf-8"), salt, iterations)
    b64 = base64.b64encode
    return f"$7${iterations}${b64(salt).decode()}${b64(digest).decode()}"


def _traversable(directory: Path, uid: int, gid: int) -> bool:
    """Whether user ``uid`` (group ``gid``) may pass through ``directory`` and its parents."""
    for d in [directory, *directory.parents]:
        st = d.stat()
        bit = (
            stat.S_IXUSR if st.st_uid == uid else stat.S_IXGRP if st.st_gid == gid else stat.S_IXOTH
        )
        if not st.st_mode & bit:
            return False
    return True


class RunningBroker(Protocol):
    """What ``write_config`` reads of a broker (``mosquitto.ManagedBroker`` has it all), so this
    module does not import the one that calls it: its settings and what its start chose."""

    settings: BrokerSettings
    dir: Path | None
    port: int | None
    tls_port: int | None
    websockets_port: int | None
    username: str
    password: str
    monitor_username: str
    monitor_password: str | None

    @property
    def plain_host(self) -> str: ...


def write_config(broker: RunningBroker) -> pwd.struct_passwd | None:
    """Writes ``broker``'s files into ``broker.dir``; returns user ``mosquitto``'s entry when
    the broker should be started as that user (as root, with no privileged port to bind)."""
    assert broker.dir is not None
    d, settings = broker.dir, broker.settings
    (d / "data").mkdir(exist_ok=True)
    users = f"{broker.username}:{mosquitto_password_hash(broker.password)}\n"
    if settings.websockets:
        assert broker.monitor_password is not None
        users += f"{broker.monitor_username}:{mosquitto_password_hash(broker.monitor_password)}\n"
    if settings.password_file is not None:  # the operator's users (hashed by mosquitto_passwd)
        users += settings.password_file.read_text(encoding="utf-8").rstrip("\n") + "\n"
    _write_private(d / "passwd", users)
    lines = [
        # password_file and allow_anonymous are global (per_listener_settings false):
        # every listener requires the credentials
        f"listener {broker.port} {broker.plain_host}",
    ]
    owned = [d, d / "data", d / "passwd"]
    if settings.tls:
        assert settings.tls_cert is not None and settings.tls_key is not None
        tls_dir = d / "tls"
        tls_dir.mkdir(exist_ok=True)
        # copies: mosquitto may run as user "mosquitto", which cannot read the originals
        shutil.copyfile(settings.tls_cert, tls_dir / "server.crt")
        shutil.copyfile(settings.tls_key, tls_dir / "server.key")
        os.chmod(tls_dir / "server.key", 0o600)
        owned += [tls_dir, tls_dir / "server.crt", tls_dir / "server.key"]
        lines += [
            f"listener {broker.tls_port} {settings.host}",
            f"certfile {tls_dir / 'server.crt'}",
            f"keyfile {tls_dir / 'server.key'}",
        ]
    if settings.websockets:
        # loopback by default (docs/monitor.md); on an external broker with TLS: docs/deployment.md
        assert broker.websockets_port is not None
        lines += websockets_listener(broker.websockets_port, settings.websockets_host)
    if settings.acl_file is not None or settings.websockets:
        acl = settings.acl_file.read_text(encoding="utf-8") if settings.acl_file is not None else ""
        if settings.websockets:
            acl += MONITOR_ACL.format(user=broker.username, monitor=broker.monitor_username)
        _write_private(d / "acl", acl)  # Mosquitto warns of a readable one
        owned.append(d / "acl")
        lines.append(f"acl_file {d / 'acl'}")
    lines += [
        "allow_anonymous false",
        f"password_file {d / 'passwd'}",
        "persistence true",
        f"persistence_location {d / 'data'}/",
        f"autosave_interval {settings.autosave_interval_s}",
        f"max_queued_messages {settings.max_queued_messages}",
        f"max_queued_bytes {settings.max_queued_bytes}",
        f"max_inflight_messages {settings.max_inflight_messages}",
        f"max_packet_size {settings.max_message_bytes + PACKET_OVERHEAD_BYTES}",
        "set_tcp_nodelay true",
        "log_dest stderr",
        "log_type error",
        "log_type warning",
        "log_type notice",
        "log_type information",
        "connection_messages true",
        "log_timestamp_format %Y-%m-%dT%H:%M:%S",
    ]
    run_as = None
    if os.geteuid() == 0:
        user_line, run_as = _root_user_line(broker, owned)
        lines.append(user_line)
    (d / "mosquitto.conf").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return run_as


def _root_user_line(
    broker: RunningBroker, paths: list[Path]
) -> tuple[str, pwd.struct_passwd | None]:
    # Mosquitto started as root drops to user "mosquitto": its files must be that user's,
    # and it must be able to reach them.
    assert broker.dir is not None
    try:
        entry = pwd.getpwnam("mosquitto")
    except KeyError:
        return "user root", None
    if not _traversable(broker.dir.resolve().parent, entry.pw_uid, entry.pw_gid):
        log.warning(
            "user mosquitto cannot reach %s (a parent directory is closed to it); "
            "running mosquitto as root",
            broker.dir,
        )
        return "user root", None
    for path in paths:
        os.chown(path, entry.pw_uid, entry.pw_gid)
    if (
        min(p for p in (broker.port, broker.tls_port, broker.websockets_port) if p is not None)
        >= 1024
    ):
        # no privileged port to bind first: start it as that user
        return "user mosquitto", entry
    return "user mosquitto", None


def _write_private(path: Path, text: str) -> None:
    """Writes ``text`` readable by its owner only (Mosquitto's password and ACL files)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.chmod(path, 0o600)  # an older file keeps its mode through O_CREAT
