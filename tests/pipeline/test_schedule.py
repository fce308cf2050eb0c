"""Scheduling bookkeeping: nothing lost, nothing issued twice without a reason."""

from datagen.pipeline.schedule import Schedule


def test_each_worker_gets_at_most_per_worker_unpublished():
    s = Schedule(range(10), ack_timeout_s=5, per_worker=2)
    s.add_worker(0)
    s.add_worker(1)
    assert s.next_for(0) == [0, 1] and s.next_for(1) == [2, 3] and s.next_for(0) == []
    s.on_published(0, 0, now=0.0)
    assert s.next_for(0) == [4]


def test_acked_samples_finish_the_schedule():
    s = Schedule(range(3), ack_timeout_s=5)
    s.add_worker(0)
    for index in [*s.next_for(0), 2]:
        s.on_published(0, index, now=0.0)
        s.next_for(0)
        s.on_acked(index)
    assert s.done and s.reissued == 0


def test_a_dead_workers_samples_are_issued_again():
    s = Schedule(range(6), ack_timeout_s=5)
    s.add_worker(0)
    s.add_worker(1)
    first = s.next_for(0)
    s.on_published(0, first[0], now=0.0)
    s.on_acked(first[0])  # durable before the worker died: not issued again
    s.next_for(1)
    assert s.on_worker_lost(0) == [first[1]]
    s.add_worker(2)
    assert s.next_for(2)[0] == first[1]


def test_unacknowledged_samples_are_issued_again_after_the_deadline():
    s = Schedule(range(4), ack_timeout_s=5)
    s.add_worker(0)
    for index in s.next_for(0):
        s.on_published(0, index, now=10.0)
    s.on_acked(0)
    assert s.reissue_overdue(now=14.0) == []
    assert s.reissue_overdue(now=15.5) == [1]
    assert s.next_for(0)[0] == 1
    # a late ack for the original delivery ends it; the re-issued copy is harmless
    s.on_acked(1)
    assert 1 not in s.remaining


def test_an_ack_while_queued_again_skips_the_sample():
    s = Schedule(range(2), ack_timeout_s=1)
    s.add_worker(0)
    s.next_for(0)
    s.on_published(0, 0, now=0.0)
    s.reissue_overdue(now=5.0)
    s.on_acked(0)
    assert 0 not in s.next_for(0)


def test_a_sample_given_up_is_done_with_but_not_durable():
    s = Schedule(range(3), ack_timeout_s=10)
    s.add_worker(0)
    assert s.next_for(0) == [0, 1]
    s.on_published(0, 0, now=0.0)
    s.on_acked(0)
    s.on_given_up(0, 1)
    assert s.not_durable == 2  # 1 given up, 2 still to make
    assert s.next_for(0) == [2]
    s.on_published(0, 2, now=0.0)
    s.on_acked(2)
    assert s.done and s.not_durable == 1


def test_nothing_new_is_issued_while_max_unacked_samples_wait_for_acks():
    schedule = Schedule(range(10), ack_timeout_s=60, per_worker=2, max_unacked=3)
    for worker in (0, 1):
        schedule.add_worker(worker)
    assert schedule.next_for(0) == [0, 1] and schedule.next_for(1) == [2, 3]
    for index in (0, 1, 2):
        schedule.on_published(index // 2, index, now=1.0)
    assert schedule.backed_up and list(schedule.hungry_workers()) == []
    assert schedule.next_for(0) == []  # three published, none durable: the writers set the pace
    schedule.on_acked(1, now=2.0)
    assert not schedule.backed_up and list(schedule.hungry_workers()) == [0, 1]
    assert schedule.next_for(0) == [4, 5]  # issued, not published: per_worker bounds those


def test_feeding_stops_at_the_first_worker_that_fills_the_bound():
    schedule = Schedule(range(20), ack_timeout_s=60, per_worker=1, max_unacked=2)
    for worker in range(5):
        schedule.add_worker(worker)
    for worker in (0, 1):
        schedule.on_published(worker, schedule.next_for(worker)[0], now=1.0)
    schedule.on_acked(0, now=2.0)  # one slot free, workers 0, 1 (and 2, 3, 4) hungry
    visited = []
    for worker in schedule.hungry_workers():
        visited.append(worker)
        schedule.on_published(worker, schedule.next_for(worker)[0], now=3.0)
    assert visited == [0] and schedule.backed_up  # not every idle worker, one per freed slot
