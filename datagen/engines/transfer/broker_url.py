"""Broker URLs: ``mqtt://[user[:pass]@]host[:port]`` (default port 1883) or ``mqtts://`` (8883).

``parse_broker_url`` reads one into a ``BrokerAddress``, ``broker_url`` builds one (user name
and password percent-encoded), and ``redact`` hides the password of a URL for printing.
"""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import quote, unquote, urlsplit


@dataclass(frozen=True)
class BrokerAddress:
    host: str
    port: int
    username: str | None
    password: str | None
    tls: bool


def parse_broker_url(url: str) -> BrokerAddress:
    """``mqtt://[user[:pass]@]host[:port]`` (default port 1883) or ``mqtts://`` (8883)."""
    try:
        parts = urlsplit(url)
        port = parts.port
    except ValueError as exc:
        raise ValueError(f"bad broker URL {url!r}: {exc}") from None
    if parts.scheme not in ("mqtt", "mqtts"):
        raise ValueError(f"bad broker URL {url!r}: scheme must be mqtt:// or mqtts://")
    if not parts.hostname:
        raise ValueError(f"bad broker URL {url!r}: no host")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(f"bad broker URL {url!r}: unexpected path, query or fragment")
    tls = parts.scheme == "mqtts"
    return BrokerAddress(
        host=parts.hostname,
        port=port if port is not None else (8883 if tls else 1883),
        username=unquote(parts.username) if parts.username is not None else None,
        password=unquote(parts.password) if parts.password is not None else None,
        tls=tls,
    )


def broker_url(scheme: str, username: str, password: str, host: str, port: int) -> str:
    """``scheme://user:password@host:port``; an IPv6 host goes in brackets."""
    host = f"[{host}]" if ":" in host else host
    return f"{scheme}://{quote(username, safe='')}:{quote(password, safe='')}@{host}:{port}"


def redact(url: str) -> str:
    """``url`` with its password, if any, replaced by ``***`` (for logs and messages).

    Splits the way ``urlsplit`` does (the user info ends at the netloc's last ``@``) but never
    raises, so even a malformed URL is printed without its password."""
    scheme, sep, rest = url.partition("://")
    if not sep:
        return url
    end = min((i for i in (rest.find(c) for c in "/?#") if i >= 0), default=len(rest))
    userinfo, at, hostport = rest[:end].rpartition("@")
    if not at or ":" not in userinfo:
        return url
    user = userinfo.partition(":")[0]
    return f"{scheme}://{user}:***@{hostport}{rest[end:]}"
