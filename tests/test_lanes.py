"""Ordered lanes on a shared thread pool (``sim.lanes``): order within a lane, lanes side by side."""
from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from trackroom.sim.lanes import Lane


def test_each_lane_runs_in_submission_order_one_at_a_time():
    seen: dict[str, list[int]] = {"a": [], "b": []}
    running = {"a": 0, "b": 0}
    lock = threading.Lock()

    def job(lane, i):
        with lock:
            running[lane] += 1
            assert running[lane] == 1  # never two jobs of one lane at once
        time.sleep(0.001 * ((i * 7) % 3))  # uneven durations: a free-for-all pool would reorder them
        seen[lane].append(i)
        with lock:
            running[lane] -= 1
        return i * i

    with ThreadPoolExecutor(max_workers=4) as pool:
        lanes = {k: Lane(pool) for k in seen}
        futures = [(k, i, lanes[k].submit(job, k, i)) for i in range(40) for k in seen]
        assert [f.result(timeout=10) for _, _, f in futures] == [i * i for _, i, _ in futures]
    assert seen == {"a": list(range(40)), "b": list(range(40))}


def test_lanes_run_side_by_side():
    """Two lanes whose first jobs wait for each other finish only if they run concurrently."""
    both = threading.Barrier(2, timeout=5)
    with ThreadPoolExecutor(max_workers=2) as pool:
        a, b = Lane(pool), Lane(pool)
        fa, fb = a.submit(both.wait), b.submit(both.wait)
        fa.result(timeout=10), fb.result(timeout=10)


def test_an_error_reaches_its_future_and_the_lane_goes_on():
    def fail():
        raise ValueError("bad frame")

    with ThreadPoolExecutor(max_workers=2) as pool:
        lane = Lane(pool)
        bad, good = lane.submit(fail), lane.submit(lambda: 7)
        with pytest.raises(ValueError, match="bad frame"):
            bad.result(timeout=10)
        assert good.result(timeout=10) == 7


def test_cancelled_jobs_are_skipped():
    gate = threading.Event()
    ran = []
    with ThreadPoolExecutor(max_workers=1) as pool:
        lane = Lane(pool)
        first = lane.submit(gate.wait, 5)
        second = lane.submit(ran.append, 2)
        third = lane.submit(ran.append, 3)
        assert second.cancel()
        gate.set()
        first.result(timeout=10), third.result(timeout=10)
    assert ran == [3] and second.cancelled()
