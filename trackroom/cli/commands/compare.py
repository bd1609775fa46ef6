"""trackroom compare: scenes x seeds x estimators -> results.csv, summary.md and plots.

Beside its results it writes ``spec.toml`` (the resolved comparison) and ``provenance.json``
(command line, versions, times); with ``--html`` also ``report.html`` (``trackroom report``). An existing ``--out`` is refused unless ``--force`` (replace its
results; the recordings cache stays, checked entry by entry) or ``--resume`` (reuse the finished
runs stored in OUT/runs; without a TOML file or --scenes it reruns OUT/spec.toml).

Where it runs: ``--jobs 1`` (the default) in this process; ``--jobs N`` on a dask ``LocalCluster``
of N worker processes; ``--scheduler ADDRESS`` on an existing dask cluster (``trackroom.cluster``).
The results table is the same whichever runs it. Progress (estimator runs, recordings, rate, ETA)
goes to stderr when it is a terminal.
"""
from __future__ import annotations

from trackroom.cli.commands import add_plugin_argument

NAME = "compare"
HELP = "compare estimators over scenes and seeds (from a TOML file or options): results.csv, summary.md, plots"


def add_arguments(p) -> None:
    p.add_argument("config", nargs="?", help="comparison TOML file (see trackroom/compare.py); options below override it")
    p.add_argument("--scenes", help="comma-separated bundled scene names or TOML paths")
    p.add_argument("--seeds", help="e.g. 0-4 or 0,3,5 (default 0)")
    p.add_argument("--estimators", help="comma-separated names, with parameters as name[k=v;k=v]; 'all' (default): every registered one")
    p.add_argument("--duration", type=float, help="simulated seconds per recording (default 20)")
    p.add_argument("--sensing", choices=["analytic", "rendered"])
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="scene override for every scene, e.g. --set walkers.count=5 (repeatable)")
    p.add_argument("--gate", type=float, help="match gate in metres (default 1); HOTA similarity max(0, 1 - d / gate)")
    p.add_argument("--jobs", type=int,
                   help="local worker processes: 1 (default) runs everything in this process, N > 1 on a dask "
                        "LocalCluster of N workers (at most one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the tasks on an existing dask cluster (e.g. tcp://10.0.0.5:8786; --jobs is then unused); "
                        "--out and --recordings must be paths every worker can reach")
    p.add_argument("--recordings", help="recordings cache folder (default OUT/recordings)")
    p.add_argument("--no-cache", action="store_true", help="simulate every recording, keep none")
    p.add_argument("--out", required=True, help="output folder (refused if it exists, unless --force or --resume)")
    p.add_argument("--force", action="store_true", help="replace the results in an existing --out")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted comparison in --out: finished runs that match are reused, not re-run")
    p.add_argument("--html", action="store_true",
                   help="also write OUT/report.html, the self-contained report (as trackroom report OUT does)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress bar (it shows estimator runs and recordings with rate and ETA on stderr, "
                        "and only on a terminal)")
    add_plugin_argument(p)


def build_spec(args):
    from pathlib import Path

    from trackroom.compare import (CompareSpec, SceneRun, all_estimators, parse_estimator, parse_seeds, spec_from_toml,
                                 split_top)
    from trackroom.errors import CommandError
    from trackroom.estimators import resolve_plugin

    if args.config:
        spec = spec_from_toml(args.config)
    elif args.resume and not args.scenes and (Path(args.out) / "spec.toml").is_file():
        spec = spec_from_toml(Path(args.out) / "spec.toml")
    else:
        if not args.scenes:
            raise CommandError("give a comparison TOML file or --scenes")
        spec = CompareSpec(scenes=[], seeds=[0], estimators=all_estimators())
    # worker processes import the plug-ins too: by module name or absolute file path
    spec.plugins = list(dict.fromkeys(spec.plugins + [resolve_plugin(p) for p in args.plugin]))
    if args.scenes:
        spec.scenes = [SceneRun(s) for s in split_top(args.scenes)]
    if args.overrides:
        spec.scenes = [SceneRun(s.name, s.overrides + tuple(args.overrides), s.label) for s in spec.scenes]
    if args.seeds:
        spec.seeds = parse_seeds(args.seeds)
    if args.estimators:
        spec.estimators = all_estimators() if args.estimators == "all" else [parse_estimator(e) for e in split_top(args.estimators)]
    for key in ("duration", "sensing", "gate", "jobs"):
        if getattr(args, key) is not None:
            setattr(spec, key, getattr(args, key))
    if args.no_cache:
        spec.recordings = None
    elif args.recordings or not spec.recordings:
        spec.recordings = args.recordings or str(Path(args.out) / "recordings")
    return spec


def run(args) -> int:
    from pathlib import Path

    from trackroom.errors import CommandError
    from trackroom.compare import OUTPUT_FILES, CompareError, run_comparison, spec_to_toml, write_outputs
    from trackroom.dataset import atomic_write

    if args.force and args.resume:
        raise CommandError("give --force (start again) or --resume (continue), not both")
    try:
        spec = build_spec(args).validate()
    except CompareError as e:
        raise CommandError(str(e)) from None
    out = Path(args.out)
    if "://" in args.out:
        raise CommandError(f"--out {args.out}: give a folder path (on a filesystem every worker mounts); URLs are not supported")
    if out.exists() and not out.is_dir():
        raise CommandError(f"{out}: exists and is not a folder")
    if out.exists() and any(out.iterdir()) and not (args.force or args.resume):
        raise CommandError(f"{out}: output folder exists (use --force to replace its results, or --resume to continue it)")
    if args.force:
        _remove_results(out, OUTPUT_FILES)
    out.mkdir(parents=True, exist_ok=True)
    command = getattr(args, "_command", None)
    atomic_write(out / "spec.toml", lambda p: p.write_text(spec_to_toml(spec)))  # first, so --resume finds it
    comp = run_comparison(spec, progress=not args.quiet, runs_dir=out / "runs", command=command, scheduler=args.scheduler)
    paths = write_outputs(comp, out, command=command)
    if args.html:
        from trackroom.report import write_report

        paths["report"] = write_report(out)
    print(paths["summary"].read_text())
    reused = f"; reused {comp.reused} finished run(s)" if comp.reused else ""
    print(f"took {comp.seconds:.1f} s ({comp.backend}){reused}; wrote {', '.join(str(p) for p in paths.values())}")
    errors = comp.results[comp.results["status"] == "error"]
    return 1 if len(errors) else 0


def _remove_results(out, names) -> None:
    """--force: remove an earlier comparison's results and stored runs (never other files, and not
    the recordings cache, whose entries are checked one by one)."""
    import shutil

    for name in names:
        (out / name).unlink(missing_ok=True)
    for p in out.glob("metric_*.png"):
        p.unlink()
    shutil.rmtree(out / "runs", ignore_errors=True)
