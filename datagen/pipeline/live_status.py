"""The build's status for people watching it: the coordinator publishes one JSON object,
retained, on ``datagen/<build_id>/live/status`` about once a second, and a last one saying
``finished: N/N durable`` or ``failed: ...`` (payload: docs/wire-format.md, 'Live status').

It is plain JSON, not signed: a monitor must never hold the build secret, so its integrity
rests on the broker's ACL (only the coordinator may publish there; docs/monitor.md). Nothing
here may slow or stop the build: publishes are QoS 0 except the final one, never waited for
but briefly at the end, and an unreachable broker only turns the status off.
``$DATAGEN_LIVE=0`` turns it off (and the workers' previews, ``live_preview``).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterable
from typing import Any, Protocol

from datagen.campaign_stats import campaign_stats
from datagen.errors import BuildError
from datagen.pipeline.result import BuildResult, Observer
from datagen.pipeline.schedule import Schedule
from datagen.transport.connection import MqttConnectError, MqttConnection
from datagen.transport.run_binding import client_id
from datagen.transport.topics import topics


class BuildProgress(Protocol):
    """What the live status reads of the coordinator (which starts it: no import back)."""

    schedule: Schedule | None
    restarts: dict[str, int]
    result: BuildResult

    @property
    def failed(self) -> dict[int, list[str]]: ...


log = logging.getLogger(__name__)
LIVE_ENV = "DATAGEN_LIVE"  # "0": no live status, no previews
STATUS_PERIOD_S = 1.0
RATE_WINDOW_S = 10.0  # samples/s is measured over this much of the recent history
MAX_HISTORY = 240  # points of (seconds since start, durable) kept; thinned when full
FINAL_WAIT_S = 2.0
MAX_WORKERS_SHOWN = 256  # beyond: the oldest lost worker leaves the table


def live_enabled() -> bool:
    return os.environ.get(LIVE_ENV, "1") != "0"


class LiveStatus:
    """Collects what the coordinator sees (events, counts) and publishes it (module doc)."""

    def __init__(self, build_id: str, total: int):
        self.build_id, self.total = build_id, total
        self.topic = topics(build_id).live_status
        self.enabled = live_enabled()
        self.conn: MqttConnection | None = None
        self.coordinator: BuildProgress | None = None
        self.started = time.time()
        self.last_sent = 0.0
        self.history: list[tuple[float, int]] = []
        self.published = 0
        self.workers: dict[int, dict[str, Any]] = {}
        self.outcomes: dict[int, dict[str, Any]] = {}  # index -> outcome (a re-issue replaces)
        self.state = "starting"
        self.message = ""
        self.told_all_durable = False

    # --- inputs -----------------------------------------------------------------------------
    def watching(self, observer: Observer) -> Observer:
        """``observer``, also reporting workers started and processes restarted to us."""

        def observe(event: str, details: dict[str, Any]) -> None:
            if event == "worker":
                self._worker(details["id"])
            elif event == "restart" and details.get("what") == "worker":
                self._worker(details["id"]).update(
                    state="lost", last_error=str(details.get("why", ""))[:300]
                )
            observer(event, details)

        return observe

    def on_event(self, worker_id: int, kind: str, payload: Any) -> None:
        """A worker's event (``datagen/pipeline/worker.py``)."""
        if kind == "done":  # recycled or stopped: off the table (a lost one stays, with why)
            self.workers.pop(worker_id, None)
            return
        worker = self._worker(worker_id)
        if kind == "ready":
            worker["state"] = "idle"
        elif kind == "started":
            worker["state"] = f"sample {payload['index']}" + (
                f" (attempt {payload['attempt']})" if payload.get("attempt") else ""
            )
        elif kind == "published":
            self.published += 1
            worker["samples"] += 1
            worker["state"] = "idle"
        elif kind in ("retried", "failed") and payload.get("failures"):
            worker["last_error"] = str(payload["failures"][-1])[:300]
        elif kind == "outcome":
            self.outcomes[payload["index"]] = payload
        elif kind in ("lost", "error"):
            worker.update(state="lost", last_error=str(payload)[:300])

    def _worker(self, worker_id: int) -> dict[str, Any]:
        if worker_id not in self.workers and len(self.workers) >= MAX_WORKERS_SHOWN:
            lost = [k for k, w in self.workers.items() if w["state"] == "lost"]
            self.workers.pop(min(lost or self.workers))
        return self.workers.setdefault(
            worker_id, {"id": worker_id, "state": "starting", "samples": 0, "last_error": ""}
        )

    # --- publishing -------------------------------------------------------------------------
    def start(self, url: str, coordinator: BuildProgress) -> None:
        self.coordinator = coordinator
        if not self.enabled:
            return
        try:
            self.conn = MqttConnection(url, client_id(self.build_id, "live"), timeout_s=5.0)
        except MqttConnectError as exc:
            log.warning("no live status for monitors (%s)", exc)
        self.state = "running"

    def tick(self) -> None:
        """Publishes the status if ``STATUS_PERIOD_S`` passed since the last one, or at once
        when every sample has just become durable (the writers now finalize)."""
        if self.conn is None:
            return
        c = self.coordinator
        all_durable = c is not None and c.schedule is not None and c.schedule.done
        if time.monotonic() - self.last_sent >= STATUS_PERIOD_S or (
            all_durable and not self.told_all_durable
        ):
            self.told_all_durable = all_durable
            self._send(qos=0)

    def finish(self) -> None:
        self.state, self.message = "finished", f"finished: {self.total}/{self.total} durable"
        self._send(qos=1, wait=True)

    def fail(self, exc: BaseException) -> None:
        if self.state == "finished":  # the dataset is complete; only the shutdown went wrong
            return
        if isinstance(exc, KeyboardInterrupt):
            why = "interrupted (Ctrl-C); --resume continues it"
        elif isinstance(exc, BuildError):
            why = str(exc).splitlines()[0] if str(exc) else "build error"
        else:
            why = f"{type(exc).__name__}: {exc}".splitlines()[0]
        self.state, self.message = "failed", f"failed: {why[:500]}"
        self._send(qos=1, wait=True)

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None

    def _send(self, qos: int, wait: bool = False) -> None:
        if self.conn is None:
            return
        self.last_sent = time.monotonic()
        try:
            info = self.conn.publish_json(self.topic, self.snapshot(), qos=qos, retain=True)
        except Exception:  # a monitor's view must never stop the build
            log.exception("live status turned off")
            self.close()
            return
        if wait:
            try:
                info.wait_for_publish(FINAL_WAIT_S)
            except (RuntimeError, ValueError) as exc:  # not connected: the broker is gone
                log.warning("the final live status was not published: %s", exc)

    def snapshot(self) -> dict[str, Any]:
        """The status object (docs/wire-format.md, 'Live status')."""
        c = self.coordinator
        assert c is not None
        now = time.time()
        durable = self.total - c.schedule.not_durable if c.schedule is not None else 0
        if self.state == "finished":
            durable = self.total
        self._record(now - self.started, durable)
        rate = self._rate()
        collector = getattr(c, "collector", None)  # set once the collector is connected
        status = {
            "v": 1,
            "build_id": self.build_id,
            "state": self._state(c),
            "message": self.message,
            "time": round(now, 3),
            "started": round(self.started, 3),
            "total": self.total,
            "durable": durable,
            "resumed_from": c.result.resumed_from,
            "published": self.published,
            "reissued": c.schedule.reissued if c.schedule is not None else 0,
            "failed_samples": len(c.failed),
            "rate": round(rate, 3),
            "eta_s": round((self.total - durable) / rate, 1) if rate > 0 else None,
            "history": [[round(t, 2), d] for t, d in self.history],
            "workers": [self.workers[k] for k in sorted(self.workers)],
            "writers": {w: s.get("state") for w, s in collector.latest_status().items()}
            if collector is not None
            else {},
            "restarts": dict(c.restarts),
            "rejected": dict(collector.rejected) if collector is not None else {},
        }
        return status | campaign_summary(self.outcomes.values())

    def _state(self, c: BuildProgress) -> str:
        if self.state == "running" and c.schedule is not None and c.schedule.done:
            return "finalizing"
        return self.state

    def _record(self, t: float, durable: int) -> None:
        self.history.append((t, durable))
        if len(self.history) > MAX_HISTORY:  # keep the first, thin the rest to every other
            self.history = self.history[:1] + self.history[2::2]

    def _rate(self) -> float:
        """Durable samples per second over the last ``RATE_WINDOW_S`` of history."""
        t1, d1 = self.history[-1]
        earlier = [(t, d) for t, d in self.history if t <= t1 - RATE_WINDOW_S]
        t0, d0 = earlier[-1] if earlier else self.history[0]
        return (d1 - d0) / (t1 - t0) if t1 > t0 else 0.0


def campaign_summary(outcomes: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Success rates of the samples' outcomes so far (:mod:`datagen.outcomes`): ``campaign`` for
    grasp attempts (:func:`datagen.campaign_stats.campaign_stats`, as in the manifest),
    ``navigation`` for episodes (success rate, mean SPL); only those present."""
    outcomes = list(outcomes)
    grasps = [o for o in outcomes if o.get("kind") == "grasp"]
    episodes = [o for o in outcomes if o.get("kind") == "navigation"]
    summary: dict[str, Any] = {}
    if grasps:
        summary["campaign"] = campaign_stats(grasps)
    if episodes:
        successes = sum(bool(o["success"]) for o in episodes)
        spl = sum(float(o.get("spl") or 0.0) for o in episodes) / len(episodes)
        summary["navigation"] = {
            "episodes": len(episodes),
            "success_rate": round(successes / len(episodes), 4),
            "spl": round(spl, 4),
        }
    return summary
