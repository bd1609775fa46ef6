"""compare on dask.distributed: a real `dask scheduler` and two `dask worker` processes on
127.0.0.1 give the same results table as one process (`--jobs 1`) and as a LocalCluster
(`--jobs 2`), with a plug-in loaded on the workers; an unreachable scheduler is one line."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
PLUGIN_FILE = ROOT / "docs" / "example_plugin" / "floor_nearest.py"
# tiny analytic runs: 2 people, 3 s, two seeds; a bundled and a plug-in estimator
ARGS = ["compare", "--scenes", "overhead_lab", "--set", "walkers.count=2", "--seeds", "0-1", "--duration", "3",
        "--estimators", "ekf,ekf[smooth=true],floor_nearest", "--plugin", str(PLUGIN_FILE), "--quiet"]
TIMING = ["runtime_s", "sim_s"]  # wall-clock columns: the only ones that may differ


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _env() -> dict[str, str]:
    return {**os.environ, "MUJOCO_GL": "egl", "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}


def _stop(procs: list[subprocess.Popen]) -> None:
    """Workers first, then the scheduler; each was started in its own session, so its process
    group holds it and anything it started."""
    for p in reversed(procs):
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """`dask scheduler` and two single-threaded `dask worker` processes on 127.0.0.1; its address."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path_factory.mktemp("dask")
    dask = [sys.executable, "-m", "dask"]
    cmds = [dask + ["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"]]
    cmds += [dask + ["worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                     "--name", f"w{i}"] for i in range(2)]
    procs = []
    try:
        for i, cmd in enumerate(cmds):
            log = open(logs / f"p{i}.log", "w")
            procs.append(subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=_env(), cwd=logs,
                                          start_new_session=True))
            if i == 0:
                _wait_for_port(port, procs[0], logs / "p0.log")
        from distributed import Client

        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=90)
        yield address
    finally:
        _stop(procs)


def _wait_for_port(port: int, proc: subprocess.Popen, log: Path, timeout: float = 60) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            pytest.fail(f"dask scheduler exited: {log.read_text()[-2000:]}")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    pytest.fail(f"dask scheduler did not listen on {port} in {timeout} s")


def _compare(out: Path, *extra: str) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "trackroom", *ARGS, "--out", str(out), *extra], capture_output=True,
                       text=True, timeout=300, env=_env(), cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    return r


def _tables(out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    return pd.read_csv(out / "results.csv").drop(columns=TIMING), pd.read_csv(out / "per_frame.csv")


def test_scheduler_and_local_cluster_give_the_serial_table(scheduler, tmp_path):
    serial = _compare(tmp_path / "serial", "--jobs", "1")
    assert "(serial)" in serial.stdout
    remote = _compare(tmp_path / "remote", "--scheduler", scheduler)
    assert f"(dask scheduler {scheduler})" in remote.stdout
    local = _compare(tmp_path / "local", "--jobs", "2")
    assert "(local cluster (2 workers))" in local.stdout
    results, per_frame = _tables(tmp_path / "serial")
    assert len(results) == 6 and (results["status"] == "ok").all(), results[["estimator", "status", "reason"]]
    assert results["estimator"].tolist() == ["ekf", "ekf[smooth=true]", "floor_nearest"] * 2
    for other in ("remote", "local"):
        r, f = _tables(tmp_path / other)
        pd.testing.assert_frame_equal(r, results)
        pd.testing.assert_frame_equal(f, per_frame)
    # the workers wrote the recordings to the shared --out, each renamed into place when complete
    recs = sorted(p.name for p in (tmp_path / "remote" / "recordings").iterdir())
    assert len(recs) == 2 and not any(n.startswith(".") for n in recs), recs
    assert all((tmp_path / "remote" / "recordings" / n / "manifest.json").is_file() for n in recs)


def test_unreachable_scheduler_is_one_line(tmp_path, monkeypatch, capsys):
    import trackroom.cluster
    from trackroom.cli import main

    monkeypatch.setattr(trackroom.cluster, "CONNECT_TIMEOUT_S", 2)
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    rc = main(["compare", "--scenes", "overhead_lab", "--set", "walkers.count=1", "--estimators", "ekf",
               "--duration", "1", "--scheduler", address, "--out", str(tmp_path / "cmp"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith(f"trackroom compare: error: cannot reach the dask scheduler at {address}"), err
    assert "\n" not in err


def test_urls_are_refused_in_one_line(tmp_path, capsys):
    from trackroom.cli import main

    base = ["compare", "--scenes", "overhead_lab", "--estimators", "ekf", "--duration", "1", "--quiet"]
    assert main(base + ["--out", "s3://bucket/cmp"]) == 2
    assert "--out s3://bucket/cmp: give a folder path" in capsys.readouterr().err
    assert main(base + ["--out", str(tmp_path / "cmp"), "--recordings", "s3://bucket/recs"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("trackroom compare: error: recordings s3://bucket/recs: give a folder path (on a filesystem every "
                   "worker mounts); URLs are not supported"), err


def test_serial_compare_does_not_import_dask(tmp_path):
    code = ("import sys; from trackroom.cli import main; "
            "main(['compare', '--scenes', 'overhead_lab', '--set', 'walkers.count=1', '--estimators', 'ekf', "
            f"'--duration', '1', '--out', {str(tmp_path / 'cmp')!r}, '--quiet']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=_env())
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip().splitlines()[-1] == "[]"


def test_local_workers_share_the_cores_for_render_threads(monkeypatch):
    """A rendered recording on each of n local workers starts its share of the cores as perception
    threads, not one per core each; the parent's environment is left as it was."""
    import os

    from trackroom.cluster import available_cores, connect

    monkeypatch.delenv("TRACKROOM_RENDER_WORKERS", raising=False)
    with connect(None, 2) as (client, _):
        # a lambda travels by value and reads the worker's own environment (os.environ.get would
        # carry this process's environment along with it)
        seen = set(client.run(lambda: __import__("os").environ.get("TRACKROOM_RENDER_WORKERS")).values())
    assert seen == {str(max(1, available_cores() // 2))}
    assert "TRACKROOM_RENDER_WORKERS" not in os.environ


def test_check_thresholds_runs_every_group_on_one_local_cluster(tmp_path, monkeypatch, capsys):
    """``check-thresholds --jobs 2`` starts one local cluster for all its (scene, sensing) groups,
    not one per group, and checks the bounds as a single process would."""
    import trackroom.cluster as cluster
    from trackroom.cli.main import main

    started = []
    real = cluster.connect

    def counting(scheduler, workers, plugins=None):
        started.append(scheduler)
        return real(scheduler, workers, plugins)

    monkeypatch.setattr(cluster, "connect", counting)
    th = tmp_path / "mine.csv"
    th.write_text("scene,sensing,estimator,metric,op,bound\n"
                  "overhead_lab,analytic,ekf,mota,>=,0.5\n"
                  "bearing_corridor,analytic,qp_smoother,mota,>=,0.5\n")
    assert main(["check-thresholds", "--thresholds", str(th), "--no-bundled", "--jobs", "2", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "overhead_lab (analytic" in out and "bearing_corridor (analytic" in out and "all 2 bounds met" in out
    local = [s for s in started if s is None]
    assert len(local) == 1  # one LocalCluster; the groups join it by its address
    assert len(started) == 3
