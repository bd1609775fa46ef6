"""Benchmark: the whole `trackroom generate` command, timed from outside the process.

    python scripts/bench_generate.py [--duration 600] [--walkers 10] [--repeats 3] [--against PYTHON]

Runs ``trackroom generate overhead_lab --set walkers.count=10 --duration 600 --sensing analytic``
as a new process (interpreter start-up, imports, simulation and writing the recording folder all
counted), ``--repeats`` times, each into a fresh temporary folder, and prints the wall time and the
process's CPU time (user + system, from the kernel's accounting of the child) of each run, and the
best and median ratio of simulated to wall seconds (target: 200x, i.e. <= 3.0 s for 600 s). The
1-minute load average is printed before and after: on a shared machine under load the wall time
of the same work rises with it, so compare runs at similar load (the CPU time moves much less).
``/usr/bin/time trackroom generate ...`` gives the same wall figure.

``--against PYTHON``: also time another build, run by that interpreter (e.g. the ``.venv/bin/python``
of a checkout of main), alternating with this one run by run so that both see the same load; the
commands run from a temporary folder, so each interpreter imports its own installed trackroom.

Measured here (2 cores shared with other jobs; README, "Simulator and analytic sensing"): best
3.06 s wall = 196x, median 3.17 s = 189x, 3.85 s CPU at load average 3.1-3.7 (issue 14 part 4);
3.55 s = 169x at load 0.7 before it; its second pass, alternated with main (``--against``) on a
busier machine: best 3.57 s (168x), median 5.50 s against main's 4.42 s and 6.76 s at load
2.2-3.4; median 10.47 s against 12.15 s at load 5.6-6.8; rebased on main 2d083a7, at load
2.3-2.7: best 3.46 s (173x), median 3.60 s against 4.18 s and 4.46 s (README has every row). The CPU figure
counts both of the command's threads (the camera side of the simulation runs beside the IMU
side), so it can exceed the wall time.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def command(out: Path, duration: float, walkers: int, python: str = sys.executable) -> list[str]:
    return [python, "-m", "trackroom", "generate", "overhead_lab", "--set", f"walkers.count={walkers}",
            "--duration", f"{duration:g}", "--sensing", "analytic", "--out", str(out), "--quiet"]


def timed(cmd: list[str], cwd: Path) -> tuple[float, float]:
    """(wall s, CPU s: user + system of the child) of one run; exits on a failed run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        print(p.stderr, file=sys.stderr)
        sys.exit(p.returncode)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0, help="simulated seconds")
    ap.add_argument("--walkers", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--against", metavar="PYTHON", help="an interpreter with another build of trackroom, alternated with this one")
    args = ap.parse_args(argv)
    builds = {"this": sys.executable} | ({"against": args.against} if args.against else {})
    tmp = Path(tempfile.mkdtemp(prefix="trackroom-bench-generate-"))
    loads = [os.getloadavg()[0]]
    walls = {b: [] for b in builds}
    cpus = {b: [] for b in builds}
    try:
        for r in range(args.repeats):
            for build, python in builds.items():
                out = tmp / f"rec{r}-{build}"
                wall, cpu = timed(command(out, args.duration, args.walkers, python), tmp)
                walls[build].append(wall)
                cpus[build].append(cpu)
                loads.append(os.getloadavg()[0])
                print(f"run {r}{' ' + build if args.against else ''}: {wall:.2f} s wall ({args.duration / wall:.0f}x real time), "
                      f"{cpu:.2f} s CPU, load average {loads[-1]:.1f}", flush=True)
                shutil.rmtree(out, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    shown = " ".join(command(Path("OUT"), args.duration, args.walkers)[3:])
    print(f"trackroom {shown}")
    for build in builds:
        w, c = walls[build], cpus[build]
        print(f"{build + ': ' if args.against else ''}best {min(w):.2f} s wall = {args.duration / min(w):.0f}x real time; "
              f"median {statistics.median(w):.2f} s = {args.duration / statistics.median(w):.0f}x; "
              f"CPU best {min(c):.2f} s, median {statistics.median(c):.2f} s")
    print(f"load average {min(loads):.1f}-{max(loads):.1f} over the runs, {os.cpu_count()} cores; target 200x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
