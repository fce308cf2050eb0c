"""What the monitor's HTTP server answers (docs/monitor.md, 'What the page trusts'): a request
whose target is a plain path and whose Host header names this server. A page of another site
can make a browser send only a Host it names itself, so the check keeps a site whose name an
attacker re-points to this machine (DNS rebinding) from reading ``config.json`` and the
monitor's password; any IP address is accepted, since only a user typing it sends one.
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Iterable
from urllib.parse import unquote

LOOPBACK_NAME = "localhost"
WILDCARD_HOSTS = ("", "0.0.0.0", "::")
# Sec-Fetch-Site values a browser sends for the page's own requests and for a typed address
OWN_FETCHES = ("same-origin", "none")


class RefusedRequest(ValueError):
    """A request the server answers with ``status`` and a one-line ``reason``."""

    def __init__(self, status: int, reason: str):
        super().__init__(reason)
        self.status, self.reason = status, reason


def _is_address(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def _is_loopback(host: str) -> bool:
    return host == LOOPBACK_NAME or (_is_address(host) and ipaddress.ip_address(host).is_loopback)


def server_names(bind_host: str, public_names: Iterable[str] = ()) -> frozenset[str]:
    """The names (besides IP addresses) a Host header may give for a server bound to
    ``bind_host``: ``localhost``, this machine's own names when it is served beyond loopback,
    and the names the operator gives (``--public-name``)."""
    names = {LOOPBACK_NAME, *public_names}
    if bind_host in WILDCARD_HOSTS or not _is_loopback(bind_host):
        names |= {socket.gethostname(), socket.getfqdn()}
        if not _is_address(bind_host) and bind_host not in WILDCARD_HOSTS:
            names.add(bind_host)
    return frozenset(name.lower().rstrip(".") for name in names if name)


def host_name(header: str) -> str:
    """``name[:port]`` or ``[v6]:port`` -> the name, lower case, without a final dot."""
    value = header.strip().lower()
    if value.startswith("["):
        name, closed, port = value[1:].partition("]")
        port = port.removeprefix(":") if closed else "x"
    else:
        name, _, port = value.partition(":")
    if port and not port.isdigit():
        raise RefusedRequest(400, f"Host {header[:80]!r}: expected name[:port]")
    return name.rstrip(".")


def check_host(headers: list[str], names: frozenset[str]) -> None:
    """Raises RefusedRequest unless the request has one Host header naming this server."""
    if len(headers) != 1:
        raise RefusedRequest(400, f"expected one Host header, got {len(headers)}")
    name = host_name(headers[0])
    if not _is_address(name) and name not in names:
        raise RefusedRequest(
            403,
            f"Host {headers[0][:80]!r} does not name this monitor "
            f"(open it by IP address, as localhost, or as a --public-name)",
        )


def check_own_fetch(sec_fetch_site: str | None) -> None:
    """Raises RefusedRequest for a read another site's page makes (browsers say so)."""
    if sec_fetch_site is not None and sec_fetch_site not in OWN_FETCHES:
        raise RefusedRequest(403, f"a {sec_fetch_site} read of config.json")


def requested_path(target: str) -> str:
    """A request target -> the decoded path it names (``/app.js``); raises RefusedRequest 400
    for anything else than ``/`` and plain segments: another form of target, an encoded
    separator, a ``.``/``..`` segment, a control character, or bytes that are not UTF-8."""
    if not target.startswith("/") or target.startswith("//"):
        raise RefusedRequest(400, "expected a path starting with a single /")
    path = target.split("?", 1)[0].split("#", 1)[0]
    if any(encoded in path.lower() for encoded in ("%2f", "%5c")):
        raise RefusedRequest(400, "an encoded / or \\ in the path")
    try:
        decoded = unquote(path, errors="strict")
    except UnicodeDecodeError:
        raise RefusedRequest(400, "the path is not UTF-8") from None
    if "\\" in decoded or any(ord(c) < 0x20 or ord(c) == 0x7F for c in decoded):
        raise RefusedRequest(400, "a control character or \\ in the path")
    if any(segment in (".", "..") for segment in decoded.split("/")):
        raise RefusedRequest(400, "a . or .. segment in the path")
    return decoded
