"""Where a sweep's tasks run: a ``dask.distributed`` cluster, local or reached by address.

``connect(None, n)`` starts a ``LocalCluster`` of n worker processes on this machine (one thread
each: the simulation and the estimators are single-threaded Python) and stops it afterwards;
``connect("tcp://host:8786", ...)`` joins an existing cluster (``dask scheduler`` and ``dask
worker`` processes started elsewhere) and leaves it running. Either way the plug-ins are imported
on every worker first, so a worker that cannot load one is named before any task runs.

dask is imported here only: commands that do not run a sweep never load it.
"""
from __future__ import annotations

import contextlib
import logging
import os

from trackroom.errors import CommandError

CONNECT_TIMEOUT_S = 20


def _load_plugins_on_worker(plugins: list[str]) -> str | None:
    """Run on each worker: import the plug-ins; the problem as one line, or None."""
    from trackroom.estimators import load_plugins

    try:
        load_plugins(plugins)
    except Exception as e:  # noqa: BLE001  (reported with the worker's address)
        return f"{type(e).__name__}: {e}"
    return None


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity; every core where that is unknown)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def connect(scheduler: str | None, workers: int, plugins: list[str] | None = None):
    """Yield ``(client, description)`` for a cluster with the plug-ins loaded on every worker."""
    from distributed import Client, LocalCluster

    cluster = None
    if scheduler is None:
        # the workers inherit this environment: MUJOCO_GL, one BLAS thread (cli.main sets both),
        # and their share of the cores for a rendered recording's perception threads (each
        # process would otherwise start one per core: n x cores threads on n workers)
        os.environ.setdefault("MUJOCO_GL", "egl")
        env = {} if "TRACKROOM_RENDER_WORKERS" in os.environ else {  # sim.rendered.WORKERS_ENV
            "TRACKROOM_RENDER_WORKERS": str(max(1, available_cores() // max(1, workers)))}
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR, env=env)
        client, what = Client(cluster), f"local cluster ({workers} workers)"
    else:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError, ValueError) as e:
            raise CommandError(f"cannot reach the dask scheduler at {scheduler}: {e}") from None
        what = f"dask scheduler {scheduler}"
    try:
        if plugins:
            problems = {w: p for w, p in client.run(_load_plugins_on_worker, list(plugins)).items() if p}
            if problems:
                worker, problem = sorted(problems.items())[0]
                raise CommandError(f"worker {worker} cannot load the plug-ins ({problem}); a plug-in must be an "
                                   "installed module or a .py file at the same path on every worker")
        yield client, what
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
