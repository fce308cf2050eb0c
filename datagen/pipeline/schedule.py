"""Which sample goes to which worker, and when a sample must be issued again.

Pure bookkeeping (no processes, no clock of its own): the coordinator reports what happened and
asks what to send. A sample is *done* only when a writer acknowledged it as durable. A sample
published but not acknowledged within the deadline (lost with a crashed broker, held by a dead
writer's session), or held by a worker that died, is issued again; writers deduplicate by key,
so a sample delivered twice is still written once.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from collections.abc import Iterable, Iterator

from datagen.index_set import IndexSet
from datagen.pipeline.latency import LatencyHistogram


class Schedule:
    """Every step costs O(1) per sample or per event, whatever the number of workers: which
    worker holds each index (``holder``), the published samples in the order they were
    published (``by_time``, so the overdue are found at its front) and the workers with room
    for more (``hungry``) are kept as they change. What it holds of the samples not yet issued
    is about a bit each: ``remaining`` is an ``IndexSet``, the fresh indices are read from it
    in ascending order as they are issued, and ``todo`` holds only the ones issued again."""

    def __init__(
        self,
        indices: Iterable[int],
        ack_timeout_s: float,
        per_worker: int = 2,
        max_unacked: int | None = None,
    ):
        # an IndexSet given is taken over, not copied
        self.remaining = indices if isinstance(indices, IndexSet) else IndexSet(indices)
        self._fresh = iter(self.remaining)  # ascending; skips what is acked before its turn
        self._next_fresh = next(self._fresh, None)
        self.todo: deque[int] = deque()  # issued again: before any fresh index
        self.ack_timeout_s = ack_timeout_s
        self.per_worker = per_worker  # samples handed to a worker and not yet published
        # published samples no writer has acked yet, at most (None: no bound): past it nothing
        # new is issued, so writers slower than the workers set the pace instead of a queue
        # growing in the broker (its memory, and every sample's latency)
        self.max_unacked = max_unacked
        self.assigned: dict[int, list[int]] = {}  # worker -> indices sent, not yet published
        self.published: dict[int, dict[int, float]] = {}  # worker -> {index: publish time}
        self.holder: dict[int, int] = {}  # index -> the worker it is assigned to or published by
        self.by_time: OrderedDict[int, float] = OrderedDict()  # published, oldest first
        self.hungry: set[int] = set()  # workers holding fewer than per_worker unpublished
        self.given_up: set[int] = set()  # failed on every attempt: not waited for, not durable
        self.reissued = 0
        self.latency = LatencyHistogram()  # published -> durable (acked), in seconds

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
        self.hungry.add(worker)

    @property
    def backed_up(self) -> bool:
        """As many published samples wait for their acks as ``max_unacked`` allows."""
        return self.max_unacked is not None and len(self.by_time) >= self.max_unacked

    def hungry_workers(self) -> Iterator[int]:
        """The workers that can take more now, in id order; it stops as soon as nothing is
        left to issue or the writers are ``backed_up`` (feeding one may make it so), so a
        freed slot costs one worker visited, not every idle one."""
        for worker in sorted(self.hungry):
            if not self.has_work or self.backed_up:
                return
            yield worker

    @property
    def has_work(self) -> bool:
        """Whether an index is waiting to be issued (it may turn out acked meanwhile)."""
        return bool(self.todo) or self._next_fresh is not None

    def _pop(self) -> int:
        if self.todo:
            return self.todo.popleft()
        index = self._next_fresh
        assert index is not None  # callers check has_work
        self._next_fresh = next(self._fresh, None)
        return index

    def next_for(self, worker: int) -> list[int]:
        """Indices to send to ``worker`` now (it keeps ``per_worker`` unpublished at most;
        none while ``backed_up``)."""
        out, held = [], self.assigned[worker]
        while len(held) < self.per_worker and self.has_work and not self.backed_up:
            index = self._pop()
            if index in self.remaining and index not in self.holder:
                held.append(index)
                self.holder[index] = worker
                out.append(index)
        if len(held) < self.per_worker:
            self.hungry.add(worker)
        else:
            self.hungry.discard(worker)
        return out

    def on_published(self, worker: int, index: int, now: float) -> None:
        held = self.assigned.get(worker)
        if held is not None and index in held:
            held.remove(index)
            self.hungry.add(worker)
        if index in self.remaining:
            self.published.setdefault(worker, {})[index] = now
            self.holder[index] = worker
            self.by_time[index] = now
            self.by_time.move_to_end(index)

    def on_acked(self, index: int, now: float | None = None) -> None:
        """A writer made ``index`` durable; with ``now``, its latency since it was published
        goes into ``latency`` (not for one whose publishing was not reported yet)."""
        if now is not None and (published_at := self.by_time.get(index)) is not None:
            self.latency.add(now - published_at)
        self.remaining.discard(index)
        self.given_up.discard(index)
        worker = self.holder.pop(index, None)
        if worker is not None:
            self.published.get(worker, {}).pop(index, None)
        self.by_time.pop(index, None)

    def on_given_up(self, worker: int, index: int) -> None:
        """Producing ``index`` failed on every allowed attempt: it is no longer waited for (the
        coordinator reports it when everything else is durable)."""
        held = self.assigned.get(worker)
        if held is not None and index in held:
            held.remove(index)
            self.hungry.add(worker)
            self._release(index, worker)
        if index in self.remaining:
            self.remaining.discard(index)
            self.given_up.add(index)

    def on_worker_lost(self, worker: int, keep_published: bool = False) -> list[int]:
        """The worker died: everything it held and nobody acknowledged is issued again. A worker
        that finished cleanly (``keep_published``) hands its published samples over to the
        ack deadline instead: the broker has them."""
        self.hungry.discard(worker)
        held = self.assigned.pop(worker, [])
        for index in held:
            self._release(index, worker)
        lost = [i for i in held if i in self.remaining]
        if not keep_published:  # else they stay tracked under the old id (ids are not reused)
            published = self.published.pop(worker, {})
            for index in published:
                self._release(index, worker)
                self.by_time.pop(index, None)
            lost += [i for i in published if i in self.remaining]
        self._reissue(lost)
        return lost

    def reissue_overdue(self, now: float) -> list[int]:
        overdue = []
        while self.by_time:
            index, published_at = next(iter(self.by_time.items()))
            if now - published_at <= self.ack_timeout_s:
                break
            del self.by_time[index]
            worker = self.holder.pop(index, None)
            if worker is not None:
                self.published.get(worker, {}).pop(index, None)
            overdue.append(index)
        self._reissue(overdue)
        return overdue

    def _release(self, index: int, worker: int) -> None:
        if self.holder.get(index) == worker:
            del self.holder[index]

    def _reissue(self, indices: list[int]) -> None:
        for index in sorted(indices, reverse=True):
            if index in self.remaining and index not in self.holder:
                self.todo.appendleft(index)
                self.reissued += 1
