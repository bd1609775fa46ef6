"""Ordered lanes on a shared thread pool: work that must run in order, next to work that need not.

A ``Lane`` runs the callables submitted to it one at a time, in submission order, on a shared
``concurrent.futures.Executor``; different lanes (and plain ``executor.submit`` jobs) run
concurrently on the pool's threads. The rendered pipeline gives each camera a lane, because its
detectors keep state from frame to frame (the flow tracker, the privacy camera's motion gate) and
its MP4 is written frame after frame, while the truth labels of a frame depend on that frame only
and go straight to the pool.

A lane holds at most one job on the pool at a time: when that job ends it submits the lane's
next callable (if any), so a long queue in one lane never keeps the pool's threads from other
lanes, and no thread ever blocks waiting for another.
"""
from __future__ import annotations

import threading
from collections import deque
from concurrent.futures import Executor, Future


class Lane:
    """Runs submitted callables in order, one at a time, on ``executor``."""

    def __init__(self, executor: Executor):
        self._executor = executor
        self._lock = threading.Lock()
        self._queue: deque = deque()
        self._busy = False  # a job of this lane is on the executor

    def submit(self, fn, *args) -> Future:
        """A ``Future`` of ``fn(*args)``, run after every callable submitted before it."""
        fut: Future = Future()
        with self._lock:
            self._queue.append((fut, fn, args))
            if self._busy:
                return fut
            self._busy = True
        self._executor.submit(self._run_next)
        return fut

    def _run_next(self) -> None:
        with self._lock:
            fut, fn, args = self._queue.popleft()
        if fut.set_running_or_notify_cancel():  # False: cancelled while queued; skip it
            try:
                fut.set_result(fn(*args))
            except BaseException as e:  # handed to whoever waits on the Future
                fut.set_exception(e)
        with self._lock:
            if not self._queue:
                self._busy = False
                return
        try:
            self._executor.submit(self._run_next)
        except RuntimeError:  # the executor was shut down (after a failure): drop what is queued
            with self._lock:
                queued, self._queue = list(self._queue), deque()
                self._busy = False
            for f, _, _ in queued:
                f.cancel()
