"""A writer's run: which run of its build it serves, and the challenge that lets a coordinator
bind it to its own run and nobody replay that (docs/wire-format.md, "Runs").

A writer with the build secret starts bound to no run: it publishes ``waiting`` with a fresh
random ``challenge`` and takes no sample it cannot check. A ``bind`` command (signed, for the
coordinator's run) is accepted only if it names this writer and echoes its current challenge;
the writer then serves that run (its keys, its samples' run, config digest and seed) and draws
a new challenge, which every later status carries: a later run of the coordinator (a
``--resume``) binds it again with that one, and a recorded bind, which echoes a spent or a
foreign challenge, binds nothing. Without a secret there is nothing to bind: every sample is
taken, as before.
"""

from __future__ import annotations

import logging
import secrets
from typing import Any

import paho.mqtt.client as mqtt

from datagen.transport.envelope import Opener, Sealer
from datagen.transport.run_binding import RunBinding
from datagen.writer.status import WriterStatus

log = logging.getLogger("datagen.writer")  # the writer process's log


class WriterBinding:
    """The run of writer ``status.writer_id``; ``held`` are samples that came before it was
    bound (at most ``hold_max``: the rest of the receive window stays free for the bind)."""

    def __init__(
        self,
        secret: bytes | None,
        sealer: Sealer,
        opener: Opener,
        status: WriterStatus,
        hold_max: int,
    ):
        self.needed = bool(secret)
        self.sealer, self.opener, self.status = sealer, opener, status
        self.run: RunBinding | None = None
        self.held: list[mqtt.MQTTMessage] = []
        self.hold_max = max(1, hold_max)
        self._spent: set[str] = set()
        self._new_challenge()

    @property
    def bound(self) -> bool:
        """True once it serves a run (always, without a secret)."""
        return not self.needed or self.run is not None

    def hold(self, msg: mqtt.MQTTMessage) -> bool:
        """Keeps a sample that came before the bind, unacknowledged; False if none may wait."""
        if len(self.held) >= self.hold_max:
            return False
        self.held.append(msg)
        return True

    def command_of_our_run(self, run: str) -> bool:
        """A command (other than ``bind``) of run ``run`` is for us; one of another run is a
        recording replayed, counted as ``wrong_run``."""
        if self.bound and run == self.sealer.run:
            return True
        self.opener.reject("wrong_run")
        log.warning("refused a command of run %r: this writer serves run %r", run, self.sealer.run)
        return False

    def bind(self, run: str, cmd: dict[str, Any]) -> bool:
        """Takes a ``bind`` command of run ``run``; True if it bound this writer to that run."""
        if cmd.get("writer") != self.status.writer_id:
            return False  # for another writer
        challenge = cmd.get("challenge")
        if challenge in self._spent:
            return False  # one we already answered, again (QoS 1, or a retry)
        if challenge != self.status.tags["challenge"]:
            self.opener.reject("stale_bind")
            log.warning(
                "refused a bind to run %r: it does not echo this writer's challenge "
                "(a recording of another run?)",
                run,
            )
            return False
        binding = RunBinding.from_fields(cmd, "bind")  # ValueError: logged by the caller
        if binding.run != run:
            raise ValueError(f"bind.run {binding.run} is not the run of its envelope {run}")
        self._spent.add(challenge)
        self.run = binding
        self.sealer.run = self.opener.run = run
        self._new_challenge()
        log.info("bound to run %s (seed %d)", run, binding.seed)
        return True

    def _new_challenge(self) -> None:
        tags = {"challenge": secrets.token_hex(16)} if self.needed else {}
        self.status.tags = tags | ({"run": self.run.run} if self.run else {})
