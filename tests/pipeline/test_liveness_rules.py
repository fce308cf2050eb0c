"""The liveness rules as pure functions (docs/liveness.md); the faults done for real are in
tests/adversarial/test_liveness.py."""

from __future__ import annotations

from datagen.pipeline.liveness import Attempt, Silence, WorkerWatch, timed_out


def test_a_silent_worker_and_a_stuck_attempt_are_told_apart():
    watch = WorkerWatch(silence_s=10, attempt_s=30)
    watch.add(0, now=0.0)
    watch.add(1, now=0.0)
    assert watch.unresponsive(now=40.0) == []  # start-up holds the GIL for seconds: grace
    watch.ready(0)
    watch.ready(1)
    watch.started(1, {"index": 7, "attempt": 1, "failures": ["attempt 0: ValueError"]}, now=1.0)
    for t in range(1, 40):  # worker 1 keeps sending heartbeats; worker 0 is silent from t = 0
        watch.heard_from(1, now=float(t))
    found = {u.worker: u for u in watch.unresponsive(now=40.0)}
    assert found[0].attempt is None and "sent nothing for 40 s" in found[0].why
    assert found[1].attempt == Attempt(7, 1, ("attempt 0: ValueError",), 1.0)
    assert "sample 7" in found[1].why
    watch.finished(1, 7)
    assert [u.worker for u in watch.unresponsive(now=40.0)] == [0]
    assert timed_out(found[1].attempt, 30)[-1].startswith("attempt 1: timed out after 30 s")


def test_a_restarted_service_has_grace_until_it_is_first_heard():
    silence = Silence(since=100.0, grace=55.0)  # a writer (re)started at t = 100
    assert silence.silent_s(now=150.0, heard=90.0) == 50.0 and silence.grace == 55.0
    assert silence.silent_s(now=150.0, heard=120.0) == 30.0 and silence.grace == 0.0
