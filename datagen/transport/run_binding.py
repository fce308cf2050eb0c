"""What binds a message to one *run* of a build, and the MQTT client ids of a run
(docs/wire-format.md, "Runs").

A build id and a secret may be reused (a script with fixed values, ``--resume``): they do not
tell one run from another. Every time a coordinator runs it draws a fresh random run id; keys
are derived from the secret *and* the run id, and a sample names its run, the digest of the
build's config and its seed. Writers learn the run from a ``bind`` command that echoes the
writer's own fresh challenge, so a recording of another run cannot bind them.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import re
import secrets
from dataclasses import dataclass
from typing import Any

RUN_ID = re.compile(r"^[0-9a-f]{32}$")
_SHA256 = re.compile(r"^[0-9a-f]{64}$")


def valid_run_id(run: object) -> bool:
    """A run id: 32 lowercase hex digits (16 random bytes); "" is outside any run."""
    return isinstance(run, str) and (run == "" or bool(RUN_ID.match(run)))


def config_digest(config: dict[str, Any]) -> str:
    """sha256 (hex) of the config's canonical JSON (sorted keys, no spaces, UTF-8)."""
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class RunBinding:
    """One run of a build: ``run`` (its id), ``config_sha256`` and ``seed`` (the build's)."""

    run: str
    config_sha256: str
    seed: int

    @classmethod
    def draw(cls, config: dict[str, Any], seed: int) -> RunBinding:
        """A new run of a build of ``config`` (``BuildConfig.to_dict()``) and ``seed``."""
        return cls(secrets.token_hex(16), config_digest(config), seed)

    @classmethod
    def from_fields(cls, fields: dict[str, Any], what: str) -> RunBinding:
        """From ``{"run", "config_sha256", "seed"}`` (a bind command, a sample header);
        ValueError naming ``what`` and the field if one is missing or mistyped."""
        run, digest, seed = fields.get("run"), fields.get("config_sha256"), fields.get("seed")
        if not isinstance(run, str) or not RUN_ID.match(run):
            raise ValueError(f"{what}.run must be 32 lowercase hex digits, got {run!r:.80}")
        if not isinstance(digest, str) or not _SHA256.match(digest):
            raise ValueError(f"{what}.config_sha256 must be 64 lowercase hex digits")
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise ValueError(f"{what}.seed must be an integer, got {seed!r:.80}")
        return cls(run, digest, seed)

    def fields(self) -> dict[str, Any]:
        return {"run": self.run, "config_sha256": self.config_sha256, "seed": self.seed}

    def mismatch(self, other: RunBinding) -> str | None:
        """Why ``other`` (what a message claims) is not this run; None if it is."""
        if other.run != self.run:
            return f"run {other.run} is not this run ({self.run})"
        if other.config_sha256 != self.config_sha256:
            return f"config_sha256 {other.config_sha256[:12]}... is not this build's config"
        if other.seed != self.seed:
            return f"seed {other.seed} is not this build's seed {self.seed}"
        return None

    def metadata_mismatch(self, metadata: Any, index: int) -> str | None:
        """Why a sample's JSON metadata disagrees with this run (its ``seed``, its ``index``,
        when it has them); None if it agrees."""
        if not isinstance(metadata, dict):
            return None
        if "seed" in metadata and metadata["seed"] != self.seed:
            return f"metadata seed {metadata['seed']!r:.40} is not this build's seed {self.seed}"
        if "index" in metadata and metadata["index"] != index:
            return f"metadata index {metadata['index']!r:.40} is not the sample's index {index}"
        return None


def client_id(build_id: str, role: str) -> str:
    """A client id of this process for ``role`` (``acks``, ``worker-3``...): unguessable (64
    random bits), new on every run, so no other client can take its session over."""
    return f"datagen-{build_id}-{role}-{secrets.token_hex(8)}"


def writer_client_id(build_id: str, writer_id: str, secret: bytes | None) -> str:
    """A writer's client id. It stays the same across restarts of the writer (its persistent
    session holds the samples sent meanwhile), so it is derived from the build secret: only a
    holder of the secret can compute it. Without a secret: ``datagen-<build>-writer-<id>``."""
    base = f"datagen-{build_id}-writer-{writer_id}"
    if not secret:
        return base
    tag = hmac.new(secret, f"client id\x00{base}".encode(), hashlib.sha256).hexdigest()[:16]
    return f"{base}-{tag}"
