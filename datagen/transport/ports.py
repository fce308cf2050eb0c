"""TCP ports of the brokers datagen starts: a free one, or whether a chosen one is taken."""

from __future__ import annotations

import errno
import socket


def free_port(host: str) -> int:
    """A port nothing listens on at ``host`` (IPv4) now: the kernel's pick."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def port_taken(host: str, port: int) -> bool:
    """Whether another socket listens on ``host:port``, tried as Mosquitto binds: with
    SO_REUSEADDR, so a port whose last connections linger in TIME_WAIT counts as free."""
    try:
        addresses = socket.getaddrinfo(
            host or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )
    except (OSError, UnicodeError):
        return False  # a host that does not resolve: Mosquitto says so
    for family, kind, proto, _, address in addresses:
        with socket.socket(family, kind, proto) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                s.bind(address)
            except OSError as exc:
                if exc.errno == errno.EADDRINUSE:
                    return True
    return False
