"""The dataset writer a build starts on this machine (unless ``--writers`` names external ones):
a ``datagen writer`` process the coordinator restarts when it dies."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from datagen.config import BuildConfig
from datagen.pipeline.worker import die_with_parent
from datagen.transport.wire import SECRET_ENV

LOCAL_WRITER_ID = "0"


class LocalWriter:
    def __init__(self, config: BuildConfig, out_dir: Path, build_id: str, secret: bytes):
        self.config, self.out_dir, self.build_id, self.secret = config, out_dir, build_id, secret
        self.process: subprocess.Popen | None = None

    def start(self, broker_url: str) -> int:
        """Starts the writer process; returns its pid."""
        max_bytes = int(self.config.transfer.max_sample_mb * 2**20) + 2**16
        command = [
            sys.executable,
            "-m",
            "datagen.cli",
            "writer",
            "--build-id",
            self.build_id,
            "--out",
            str(self.out_dir),
            "--writer-id",
            LOCAL_WRITER_ID,
            "--shard-size",
            str(self.config.output.shard_size),
            "--max-message-bytes",
            str(max_bytes),
            # a dead writer's session holds its share only until re-issue would cover it anyway
            "--session-expiry",
            str(round(self.config.transfer.ack_timeout_s)),
            "--log-level",
            os.environ.get("DATAGEN_LOG_LEVEL", "WARNING"),
        ]
        # the broker URL carries the build's password: the environment, not argv, carries it;
        # own session: a terminal's Ctrl-C reaches only the coordinator, which stops the writer
        self.process = subprocess.Popen(
            command,
            env=os.environ | {"DATAGEN_BROKER_URL": broker_url, SECRET_ENV: self.secret.hex()},
            start_new_session=True,
            preexec_fn=die_with_parent,
        )
        return self.process.pid

    @property
    def exit_code(self) -> int | None:
        """None while it runs (or before it started)."""
        return None if self.process is None else self.process.poll()

    def wait(self, timeout_s: float) -> None:
        if self.process is not None:
            self.process.wait(timeout=timeout_s)

    def kill(self) -> None:
        """SIGKILL: ends a writer that stopped answering (a stopped process too)."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait()

    def stop(self) -> None:
        if self.process is None or self.process.poll() is not None:
            return
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
