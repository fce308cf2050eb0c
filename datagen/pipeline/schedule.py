"""Which sample goes to which worker, and when a sample must be issued again.

Pure bookkeeping (no processes, no clock of its own): the coordinator reports what happened and
asks what to send. A sample is *done* only when a writer acknowledged it as durable. A sample
published but not acknowledged within the deadline (lost with a crashed broker, held by a dead
writer's session), or held by a worker that died, is issued again; writers deduplicate by key,
so a sample delivered twice is still written once.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable


class Schedule:
    def __init__(self, indices: Iterable[int], ack_timeout_s: float, per_worker: int = 2):
        self.todo: deque[int] = deque(sorted(indices))
        self.remaining = set(self.todo)
        self.ack_timeout_s = ack_timeout_s
        self.per_worker = per_worker  # samples handed to a worker and not yet published
        self.assigned: dict[int, list[int]] = {}  # worker -> indices sent, not yet published
        self.published: dict[int, dict[int, float]] = {}  # worker -> {index: publish time}
        self.given_up: set[int] = set()  # failed on every attempt: not waited for, not durable
        self.reissued = 0

    @property
    def done(self) -> bool:
        return not self.remaining

    @property
    def not_durable(self) -> int:
        """Samples of the schedule that no writer acknowledged: to make, or given up."""
        return len(self.remaining) + len(self.given_up)

    def add_worker(self, worker: int) -> None:
        self.assigned[worker] = []
        self.published[worker] = {}

    def next_for(self, worker: int) -> list[int]:
        """Indices to send to ``worker`` now (it keeps ``per_worker`` unpublished at most)."""
        out = []
        while len(self.assigned[worker]) < self.per_worker and self.todo:
            index = self.todo.popleft()
            if index in self.remaining and not self._in_flight(index):
                self.assigned[worker].append(index)
                out.append(index)
        return out

    def on_published(self, worker: int, index: int, now: float) -> None:
        if index in self.assigned.get(worker, []):
            self.assigned[worker].remove(index)
        if index in self.remaining:
            self.published[worker][index] = now

    def on_acked(self, index: int) -> None:
        self.remaining.discard(index)
        self.given_up.discard(index)
        for indices in self.published.values():
            indices.pop(index, None)

    def on_given_up(self, worker: int, index: int) -> None:
        """Producing ``index`` failed on every allowed attempt: it is no longer waited for (the
        coordinator reports it when everything else is durable)."""
        if index in self.assigned.get(worker, []):
            self.assigned[worker].remove(index)
        if index in self.remaining:
            self.remaining.discard(index)
            self.given_up.add(index)

    def on_worker_lost(self, worker: int, keep_published: bool = False) -> list[int]:
        """The worker died: everything it held and nobody acknowledged is issued again. A worker
        that finished cleanly (``keep_published``) hands its published samples over to the
        ack deadline instead: the broker has them."""
        lost = [i for i in self.assigned.pop(worker, []) if i in self.remaining]
        if not keep_published:  # else they stay tracked under the old id (ids are not reused)
            lost += [i for i in self.published.pop(worker, {}) if i in self.remaining]
        self._reissue(lost)
        return lost

    def reissue_overdue(self, now: float) -> list[int]:
        overdue = []
        for indices in self.published.values():
            for index, published_at in list(indices.items()):
                if now - published_at > self.ack_timeout_s:
                    del indices[index]
                    overdue.append(index)
        self._reissue(overdue)
        return overdue

    def _in_flight(self, index: int) -> bool:
        return any(index in a for a in self.assigned.values()) or any(
            index in p for p in self.published.values()
        )

    def _reissue(self, indices: list[int]) -> None:
        for index in sorted(indices, reverse=True):
            if index in self.remaining and not self._in_flight(index):
                self.todo.appendleft(index)
                self.reissued += 1
