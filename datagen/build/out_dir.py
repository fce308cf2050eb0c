"""The output directory of a build and its identity (``DIR/build.json``): a build id that names
its MQTT topics and a secret that signs its samples. An interrupted build resumes with the same
identity; a directory holding something else is never mixed into."""

from __future__ import annotations

import json
import os
import secrets
import shutil
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from datagen.config import BuildConfig
from datagen.engines.transfer.wire import SECRET_ENV, parse_secret
from datagen.errors import BuildError
from datagen.shards import MANIFEST, write_manifest

BUILD_STATE = "build.json"


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@dataclass(frozen=True)
class BuildIdentity:
    build_id: str
    secret: bytes  # signs every sample; writers with it reject samples not signed with it


def prepare_out_dir(
    out_dir: Path, config: BuildConfig, overwrite: bool, resume: bool, build_id: str | None
) -> tuple[BuildIdentity | None, bool]:
    """Returns (build identity, already complete). Refuses to mix builds in one directory."""
    manifest = _read_json(out_dir / MANIFEST)
    if (
        not overwrite
        and manifest
        and manifest.get("config") == config.to_dict()
        and manifest.get("samples") == config.num_samples
    ):
        return None, True
    state = _read_json(out_dir / BUILD_STATE)
    if resume and not overwrite:
        if state is None:
            raise BuildError(
                f"{out_dir}: nothing to resume (no {BUILD_STATE}); start it without --resume"
            )
        if state.get("config") != config.to_dict():
            differing = sorted(
                k for k in config.to_dict() if state.get("config", {}).get(k) != config.to_dict()[k]
            )
            raise BuildError(
                f"{out_dir} was started with another config (differs in: {', '.join(differing)}); "
                "resume with the same config, seed and sample count"
            )
        try:
            return BuildIdentity(state["build_id"], parse_secret(state["secret"])), False
        except (KeyError, ValueError) as exc:
            raise BuildError(f"{out_dir / BUILD_STATE}: unreadable build state ({exc})") from None
    if out_dir.exists() and any(out_dir.iterdir()):
        if not overwrite:
            hint = " or pass --resume to finish it" if state else ""
            raise BuildError(
                f"{out_dir} is not empty and does not hold a complete build of this config "
                f"(same config, seed and sample count); choose another --out{hint}, "
                f"or pass --overwrite to replace it"
            )
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        secret = parse_secret(os.environ[SECRET_ENV]) if os.environ.get(SECRET_ENV) else None
    except ValueError as exc:
        raise BuildError(str(exc)) from None
    identity = BuildIdentity(build_id or secrets.token_hex(6), secret or secrets.token_bytes(32))
    state = {
        "build_id": identity.build_id,
        "secret": identity.secret.hex(),
        "config": config.to_dict(),
        "started_utc": now_utc(),
    }
    write_manifest(out_dir, state, name=BUILD_STATE, mode=0o600)  # it holds the secret
    return identity, False


def now_utc() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")
