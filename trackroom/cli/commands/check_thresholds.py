"""trackroom check-thresholds: the CI accuracy check, on the bundled bounds and the user's own.

For every (scene, sensing) with bounds, run the small CI comparison (``metrics.thresholds``:
``CI_RUNS``, seeds ``CI_SEEDS``) of the estimators with bounds there, and check each bound
against the mean over seeds. User files (``--thresholds``, same format as the bundled
``metrics/thresholds.csv``) are laid over the bundled file: a user row with the same scene,
sensing, estimator, metric and op replaces the bundled one. Exit status 1 when a bound fails,
with the table of failures.
"""
from __future__ import annotations

import contextlib
import os

from trackroom.cli.commands import add_plugin_argument

NAME = "check-thresholds"
HELP = "run the CI accuracy comparison for the bundled thresholds and your own (--thresholds); exit 1 when a bound fails"


def add_arguments(p) -> None:
    p.add_argument("--thresholds", action="append", default=[], metavar="PATH",
                   help="a thresholds CSV of your own (scene, sensing, estimator, metric, op, bound), laid over the "
                        "bundled one: a row for the same scene/sensing/estimator/metric/op replaces it (repeatable)")
    p.add_argument("--no-bundled", action="store_true", help="check only the --thresholds files, not the bundled bounds")
    p.add_argument("--jobs", type=int, default=1, help="local worker processes (default 1: in this process; N > 1: a dask LocalCluster)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_plugin_argument(p)


def run(args) -> int:
    import pandas as pd

    from trackroom.compare import CompareError, ci_spec, run_comparison
    from trackroom.errors import CommandError
    from trackroom.estimators import resolve_plugin
    from trackroom.metrics.thresholds import ThresholdError, check_thresholds, failure_table, load_merged

    if args.no_bundled and not args.thresholds:
        raise CommandError("--no-bundled needs at least one --thresholds file")
    if args.jobs < 1:
        raise CommandError(f"--jobs must be at least 1, got {args.jobs}")
    try:
        th = load_merged(args.thresholds, bundled=not args.no_bundled)
    except ThresholdError as e:
        raise CommandError(str(e)) from None
    if not len(th):
        raise CommandError("no bounds to check")
    plugins = [resolve_plugin(p) for p in args.plugin]
    groups = list(dict.fromkeys(zip(th["scene"], th["sensing"])))
    try:
        specs = [ci_spec(th, scene, sensing, args.jobs, plugins).validate() for scene, sensing in groups]
    except CompareError as e:
        raise CommandError(str(e)) from None
    checked = []
    with _one_cluster(args.jobs, plugins) as scheduler:  # every group's runs on the same workers
        for (scene, sensing), spec in zip(groups, specs):
            comp = run_comparison(spec, progress=not args.quiet, scheduler=scheduler)
            rows = th[(th["scene"] == scene) & (th["sensing"] == sensing)]
            c = check_thresholds(comp.results, rows)
            print(f"{scene} ({sensing}, {len(spec.seeds)} seeds, {spec.duration:g} s): {int(c['passed'].sum())} of "
                  f"{len(c)} bounds met ({comp.seconds:.1f} s)")
            checked.append(c)
    allc = pd.concat(checked, ignore_index=True)
    table = failure_table(allc)
    if table:
        print(table)
        return 1
    print(f"all {len(allc)} bounds met")
    return 0


@contextlib.contextmanager
def _one_cluster(jobs: int, plugins: list[str]):
    """The scheduler address of one local dask cluster for every group (``jobs`` > 1), started once
    and stopped at the end, instead of a cluster per group; None (run in this process) for 1."""
    if jobs <= 1:
        yield None
        return
    from trackroom.cluster import connect

    with connect(None, min(jobs, os.cpu_count() or 1), plugins) as (client, _):
        yield client.scheduler.address
