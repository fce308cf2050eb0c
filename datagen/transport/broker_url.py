"""Broker URLs: ``mqtt://[user[:pass]@]host[:port]`` (default port 1883) or ``mqtts://`` (8883).

``parse_broker_url`` reads one into a ``BrokerAddress``, ``broker_url`` builds one (user name
and password percent-encoded), and ``redact`` hides the password of a URL for printing. Every
error message shows the URL redacted: a broker URL is a secret (docs/deployment.md, Security).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from urllib.parse import quote, unquote, urlsplit

BROKER_URL_ENV = "DATAGEN_BROKER_URL"  # the coordinator's (and writers') broker URL
WORKER_BROKER_URL_ENV = "DATAGEN_WORKER_BROKER_URL"  # the workers' own, when it differs
# several brokers the samples are spread over: a build's, comma-separated; a writer's, one
SAMPLE_BROKER_URLS_ENV = "DATAGEN_SAMPLE_BROKER_URLS"
SAMPLE_BROKER_URL_ENV = "DATAGEN_SAMPLE_BROKER_URL"


@dataclass(frozen=True)
class BrokerAddress:
    host: str
    port: int
    username: str | None
    password: str | None = field(repr=False)
    tls: bool


def parse_broker_url(url: str) -> BrokerAddress:
    """``mqtt://[user[:pass]@]host[:port]`` (default port 1883) or ``mqtts://`` (8883).
    ValueError says what is wrong, showing the URL without its password."""

    def bad(why: str) -> ValueError:
        return ValueError(f"bad broker URL {redact(url)!r}: {why}")

    start = url.find("://") + 3 if "://" in url else 0
    if any(c in url[start : max(start, url.rfind("@"))] for c in "/?#"):
        raise bad("percent-encode '/', '?' and '#' in the user name and password (e.g. %2F)")
    try:
        parts = urlsplit(url)
        port = parts.port
    except ValueError:  # its text may quote a piece of the password: not shown
        raise bad("expected [user[:password]@]host[:port], the port a number 0-65535") from None
    if parts.scheme not in ("mqtt", "mqtts"):
        raise bad("scheme must be mqtt:// or mqtts://")
    if not parts.hostname:
        raise bad("no host")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise bad("unexpected path, query or fragment")
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

    Never raises, and errs on the side of hiding: the user info is taken to end at the URL's
    last ``@`` (even past a ``/``, ``?`` or ``#``, which a password should not hold unencoded),
    and a URL without ``scheme://`` is redacted all the same."""
    scheme, sep, rest = url.partition("://")
    if not sep:
        scheme, rest = "", url
    userinfo, at, hostport = rest.rpartition("@")
    if not at or ":" not in userinfo:
        return url
    user = userinfo.partition(":")[0]
    return f"{scheme}{sep}{user}:***@{hostport}"
