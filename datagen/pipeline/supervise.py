"""Supervising the services a build depends on: the broker and the writers (docs/liveness.md).

What the build started itself (a managed broker, the local writer) is restarted when it exits
or stops answering: the broker when no probe got an answer for ``build.broker_timeout_s``
(killed, then started again on the same port with its saved state), the writer when it sent
nothing (its status repeats every 2 s) for ``build.writer_timeout_s``. A writer that stopped
because its disk is full (its status ``error`` with ``disk full: PATH``, exit status 5) is not:
the build stops saying so, and ``--resume`` finishes it once there is room. What runs
elsewhere (an external broker or writer) cannot be restarted from here: it is reported with what
to do, and if it stays silent ``build.outage_wait_s`` longer the build stops with a
:class:`BuildError`; the samples already durable stay, and ``--resume`` finishes the build later.

Writers are judged only while the broker answers: a hung broker silences every writer too. The
finalize round (:meth:`Supervisor.finalize`) is bounded in time, and a broker restarted during
it gets the command again.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable
from typing import Any

from datagen.config import BuildConfig
from datagen.errors import BuildError
from datagen.pipeline.liveness import Silence
from datagen.pipeline.local_writer import LOCAL_WRITER_ID, LocalWriter
from datagen.pipeline.result import Observer
from datagen.transport.broker_url import parse_broker_url
from datagen.transport.broker_watch import PROBE_INTERVAL_S, BrokerWatch
from datagen.transport.collector import AckCollector
from datagen.transport.mosquitto import ManagedBroker
from datagen.transport.run_binding import client_id
from datagen.writer.dataset_writer import EXIT_DISK_FULL

log = logging.getLogger("datagen.pipeline.coordinator")
MAX_RESTARTS = 10  # of each kind (worker, writer, broker) before the build gives up
WRITER_READY_TIMEOUT_S = 60.0  # a (re)started writer's time to recover its shards and announce
MISSED_PROBE_S = PROBE_INTERVAL_S + 1.0  # no answer for this long: at least one probe failed
RECONNECT_S = 10.0  # after the broker answers again, clients reconnect (paho waits up to 5 s)


class Supervisor:
    """``check()`` from the coordinator's loops; ``restarts`` is the build's count by kind and
    ``missing(reason)`` words a failure with the samples still missing."""

    def __init__(
        self,
        config: BuildConfig,
        build_id: str,
        url: str,
        broker: ManagedBroker | None,
        writer: LocalWriter | None,
        writer_ids: list[str],
        observer: Observer,
        restarts: dict[str, int],
        missing: Callable[[str], str],
    ):
        self.limits, self.build_id = config.build, build_id
        self.url, self.broker, self.writer, self.writer_ids = url, broker, writer, writer_ids
        self.observer, self.restarts, self.missing = observer, restarts, missing
        self.collector: AckCollector | None = None  # set once it is connected
        self.watch = BrokerWatch(url, client_id(build_id, "probe"))
        now = time.monotonic()
        self.broker_silence = Silence(now)
        self.broker_doubted = False  # a probe failed since the broker last answered
        self.writer_silence = {w: Silence(now) for w in writer_ids}
        address = parse_broker_url(url)
        self.broker_address = f"{address.host}:{address.port}"

    def __enter__(self) -> Supervisor:
        self.watch.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.watch.close()

    # --- the broker ----------------------------------------------------------------------------
    def broker_answers(self) -> bool:
        return self.watch.silent_s() <= MISSED_PROBE_S

    def check(self, writers: bool = True) -> bool:
        """Restarts, reports or gives up on what stopped answering; ``writers=False`` judges the
        broker alone (before the writers are ready, and while they finalize). True when the
        broker answers."""
        now = time.monotonic()
        answers = self._check_broker(now)
        if writers:
            self._stop_on_full_disk()
            self._check_local_writer_exit()
            if answers:
                self._check_writers(now)
        return answers

    def _check_broker(self, now: float) -> bool:
        if self.broker is not None and not self.broker.running:
            self._restart_broker("stopped")
            return False
        silent = self.watch.silent_s()
        if silent > MISSED_PROBE_S:
            self.broker_doubted = True
        elif self.broker_doubted:  # it answers again: the writers reconnect before they count
            self.broker_doubted = False
            self._excuse_writers(now)
        if silent <= self.limits.broker_timeout_s:
            if self.broker_silence.reported:
                log.warning("the broker at %s answers again", self.broker_address)
                self.broker_silence.reported = False
            return not self.broker_doubted
        if self.broker is not None:
            self.broker.kill()  # SIGKILL: a stopped or wedged process too
            self._restart_broker(f"has not answered for {silent:.0f} s (build.broker_timeout_s)")
            return False
        self._report_or_give_up(
            self.broker_silence,
            f"the broker at {self.broker_address} has not answered for {silent:.0f} s: is it "
            f"running? (if its process was stopped: kill -CONT it).",
            silent - self.limits.broker_timeout_s,
        )
        return False

    def _restart_broker(self, why: str) -> None:
        assert self.broker is not None
        self.restarts["broker"] += 1
        if self.restarts["broker"] > MAX_RESTARTS:
            raise BuildError(self.missing("the broker keeps failing"))
        log.warning("the broker %s; starting it again on the same port with its saved state", why)
        self.observer("restart", {"what": "broker", "why": why})
        self.broker.start()
        self.watch.reset()
        self.broker_doubted = False
        self._excuse_writers(time.monotonic())
        self.observer("broker", {"url": self.broker.url, "pid": self.broker.pid})

    # --- the writers ---------------------------------------------------------------------------
    def _excuse_writers(self, now: float) -> None:
        """The broker was away: a writer's silence counts again from now, after it reconnects."""
        for silence in self.writer_silence.values():
            silence.since = max(silence.since, now)
            silence.grace = max(silence.grace, RECONNECT_S)

    def wait_writers_ready(self, on_ready: Callable[[dict[str, Any]], None]) -> None:
        """Waits for each writer's ``ready`` status (``on_ready`` gets it), our own writer's
        exit and a silent writer each ending the build with what to do."""
        assert self.collector is not None
        for writer_id in self.writer_ids:
            deadline = time.monotonic() + WRITER_READY_TIMEOUT_S
            while True:
                self.check(writers=False)
                if self.writer is not None and self.writer.exit_code is not None:
                    raise BuildError(
                        f"the dataset writer {writer_ended(self.writer)} before it was ready"
                    )
                with contextlib.suppress(TimeoutError):
                    on_ready(self.collector.wait_status("ready", writer=writer_id, timeout_s=0.5))
                    break
                if time.monotonic() > deadline:
                    raise BuildError(
                        f"writer {writer_id!r} is not ready on the broker after "
                        f"{WRITER_READY_TIMEOUT_S:.0f} s; start it with: datagen writer "
                        f"--build-id {self.build_id} --writer-id {writer_id} --out DIR, with "
                        f"$DATAGEN_BROKER_URL set to the broker's URL and $DATAGEN_BUILD_SECRET "
                        f"to the secret in DIR/build.json" + unsigned_hint(self.collector.rejected)
                    )

    def start_writer(self) -> None:
        assert self.writer is not None
        pid = self.writer.start(self.url)
        grace = max(0.0, WRITER_READY_TIMEOUT_S - self.limits.writer_timeout_s)
        self.writer_silence[LOCAL_WRITER_ID] = Silence(time.monotonic(), grace)
        self.observer("writer", {"id": LOCAL_WRITER_ID, "pid": pid})

    def _check_local_writer_exit(self) -> None:
        if self.writer is None or self.writer.exit_code is None:
            return
        if self.writer.exit_code == EXIT_DISK_FULL:
            raise BuildError(self.missing(f"the dataset writer {writer_ended(self.writer)}"))
        self._restart_writer(f"exited with code {self.writer.exit_code}")

    def _stop_on_full_disk(self) -> None:
        """A writer that stopped on a full disk says so in its last status (``disk full:
        PATH``): restarting it or waiting for it cannot help."""
        assert self.collector is not None
        for writer_id, status in self.collector.latest_status().items():
            reason = status.get("reason") if status.get("state") == "error" else None
            if writer_id in self.writer_ids and str(reason).startswith("disk full"):
                raise BuildError(
                    self.missing(f"writer {writer_id!r} stopped: {reason}; what is durable stays")
                )

    def _restart_writer(self, why: str) -> None:
        self.restarts["writer"] += 1
        if self.restarts["writer"] > MAX_RESTARTS:
            raise BuildError(self.missing(f"the writer keeps failing (it {why})"))
        log.warning("the dataset writer %s; starting it again", why)
        self.observer("restart", {"what": "writer", "why": why})
        self.start_writer()

    def _check_writers(self, now: float) -> None:
        assert self.collector is not None
        timeout = self.limits.writer_timeout_s
        answered = now - self.watch.silent_s()  # a writer's silence counts while the broker answers
        for writer_id, silence in self.writer_silence.items():
            silent = silence.silent_s(answered, self.collector.last_heard(writer_id))
            if silent <= timeout + silence.grace:
                if silence.reported:
                    log.warning("writer %r answers again", writer_id)
                    silence.reported = False
                continue
            if self.writer is not None:
                self.writer.kill()  # SIGKILL: a stopped or wedged process too
                self._restart_writer(f"sent nothing for {silent:.0f} s (build.writer_timeout_s)")
                continue
            self._report_or_give_up(
                silence,
                f"writer {writer_id!r} has sent nothing for {silent:.0f} s: is it running? (if "
                f"its process was stopped: kill -CONT it).",
                silent - timeout,
            )

    def _report_or_give_up(self, silence: Silence, problem: str, over_s: float) -> None:
        wait = self.limits.outage_wait_s
        if not silence.reported:
            silence.reported = True
            log.warning("%s The build waits %.0f s more, then stops.", problem, wait)
            self.observer("stall", {"problem": problem, "wait_s": wait})
        if over_s > wait:
            raise BuildError(
                self.missing(
                    f"{problem} The build waited {wait:.0f} s more (build.outage_wait_s) and "
                    f"stops; what is durable stays: once it answers, run the same command with "
                    f"--resume to finish the build"
                )
            )

    # --- the last phase ------------------------------------------------------------------------
    def finalize(self, total: int, manifest: dict[str, Any], timeout_s: float) -> None:
        """Asks the writers to finalize; waits for the leader's answer while a hung managed
        broker is restarted (the command is then sent again: the restart may have lost it).
        Writers are not judged meanwhile: hashing big shards may keep them quiet."""
        assert self.collector is not None
        collector = self.collector
        round_ = collector.send_finalize(total, manifest, self.writer_ids, timeout_s)
        deadline = time.monotonic() + timeout_s
        broker_restarts = self.restarts["broker"]
        while True:
            with contextlib.suppress(TimeoutError):
                status = collector.wait_finalized(round_, timeout_s=0.5)
                break
            self.check(writers=False)
            self._stop_on_full_disk()
            if self.restarts["broker"] != broker_restarts:
                broker_restarts = self.restarts["broker"]
                collector.resend(round_)
            code = self.writer.exit_code if self.writer is not None else None
            if code == 0:
                return  # it finished; its last status may have gone with the broker: disk decides
            if code is not None:
                raise BuildError(f"the dataset writer {writer_ended(self.writer)} while finalizing")
            if time.monotonic() > deadline:
                raise BuildError(
                    f"the writers did not finish the dataset within {timeout_s:.0f} s; their "
                    f"last status: {collector.latest_status()}"
                )
        if status.get("state") != "finalized":
            raise BuildError(
                f"the writers could not finalize the dataset: {status.get('reason', status)}"
            )


def writer_ended(writer: LocalWriter) -> str:
    """How the local writer ended, for a report: a full disk is named, with the directory."""
    if writer.exit_code == EXIT_DISK_FULL:
        return f"stopped: disk full in {writer.out_dir}; what is durable stays"
    return f"exited with code {writer.exit_code}"


def unsigned_hint(rejected: dict[str, int]) -> str:
    """Why a writer may not have been heard: what the coordinator dropped, if anything."""
    if not rejected:
        return ""
    if rejected.get("wrong_version"):
        return (
            f" (the coordinator dropped control-plane messages of another envelope version: "
            f"{rejected}; the writers and the build must run the same datagen)"
        )
    return (
        f" (the coordinator dropped control-plane messages it could not authenticate: "
        f"{rejected}; a writer without the build secret sends unsigned ones)"
    )
