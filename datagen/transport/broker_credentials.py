"""A broker's own user: given, kept in its data dir from an earlier start, or generated (and
kept there, mode 0600, so a restarted long-lived broker keeps its URL)."""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

from datagen.errors import DatagenError

CREDENTIALS_FILE = "credentials.json"


class CredentialsFileError(DatagenError, ValueError):
    """A data dir's credentials file cannot be read as the broker wrote it."""


def broker_credentials(
    data_dir: Path | None, username: str | None, password: str | None
) -> tuple[str, str]:
    """(username, password): the given pair; else, with a ``data_dir``, the pair saved there
    when it has the given username (or none was given); else a generated password (and
    username, unless given), saved in ``data_dir`` when there is one."""
    if username is not None and password is not None:
        return username, password
    saved_path = data_dir / CREDENTIALS_FILE if data_dir is not None else None
    saved = _saved(saved_path) if saved_path is not None and saved_path.is_file() else None
    if password is None and saved and username in (None, saved["username"]):
        return saved["username"], saved["password"]
    username = username or (saved or {}).get("username") or "datagen-" + secrets.token_hex(4)
    if password is not None:
        return username, password
    password = secrets.token_urlsafe(18)
    if saved_path is not None:
        saved_path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(saved_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"username": username, "password": password}, f)
    return username, password


def _saved(path: Path) -> dict[str, str]:
    try:
        if path.stat().st_size > 4096:
            raise ValueError("larger than 4 KiB")
        saved = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(saved, dict) or not all(
            isinstance(saved.get(key), str) and saved[key] for key in ("username", "password")
        ):
            raise ValueError("not an object with a username and a password")
    except (OSError, ValueError) as error:
        raise CredentialsFileError(
            f"{path}: expected the broker's saved credentials, a JSON object with a username "
            f"and a password ({error}); delete it to generate new ones"
        ) from None
    return saved
