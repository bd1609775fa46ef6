"""trackroom calibrate-sensing: fit analytic sensing's perception model to rendered recordings.

Reads rendered recordings (folders, or folders holding them; each keeps its resolved scene in
``scene.toml``, its seed and duration in the manifest) or renders them first (``--render SCENE``
with ``--seeds``), measures every detector against the analytic view of the same walkers
(``sim.perception_fit``), fits the model by counting, then by simulation (``--rounds``: the model
is simulated on the same scenes and seeds, ``--draws`` perception draws each, and its rates scaled by rendered / analytic), and writes it (``--out``, JSON; a scene uses it with
``sensors.perception = "PATH"``). Then it simulates analytic recordings with the fitted model on
the same scenes and seeds, measures them the same way, and prints the fitted parameters and a
table per detector, rendered beside analytic (``--table`` also writes it as CSV).
"""
from __future__ import annotations

NAME = "calibrate-sensing"
HELP = "fit analytic sensing's perception model to rendered recordings; print rendered vs analytic detector statistics"


def add_arguments(p) -> None:
    p.add_argument("recordings", nargs="*", metavar="DIR",
                   help="rendered recording folders, or folders holding them (searched for manifest.json)")
    p.add_argument("--render", action="append", default=[], metavar="SCENE",
                   help="render this scene first at --seeds (repeatable; written under --recordings)")
    p.add_argument("--seeds", default="100,101", help="seeds to render, e.g. 100,101 or 100-104 (default 100,101)")
    p.add_argument("--duration", type=float, default=30.0, help="seconds per rendered recording (default 30)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field of the --render scenes (repeatable)")
    p.add_argument("--recordings", dest="rec_dir", default="calibration_recordings",
                   help="where --render writes its recordings (default calibration_recordings/)")
    p.add_argument("--out", required=True, help="model file to write (JSON)")
    p.add_argument("--table", help="also write the rendered-vs-analytic table here (CSV)")
    p.add_argument("--rounds", type=int, default=2,
                   help="rounds of fitting by simulation after counting: each simulates the model on the same scenes and "
                        "seeds and scales its rates by rendered / analytic (default 2; 0: counts only)")
    p.add_argument("--draws", type=int, default=1,
                   help="perception draws per recording in each simulation (rounds and the final table): the rates "
                        "are corrected by their means over the draws, not by one draw's noise (default 1)")
    p.add_argument("--only", metavar="DETECTORS",
                   help="refit only these detectors (comma-separated, e.g. overhead,privacy) and keep the others "
                        "from --base; the recordings need only show these detectors")
    p.add_argument("--base", default="fitted",
                   help="with --only: the model the other detectors come from (default: the bundled model)")
    p.add_argument("--pooled-edges", action="store_true",
                   help="fit the flow windows' edge errors in one table each, crowded or not (no *_crowded tables; "
                        "the bundled model is fitted so)")
    p.add_argument("--by-height", action="store_true",
                   help="fit the flow windows' edge errors by the person's image height too: tables per height bin "
                        "(sim.analytic_detectors.EDGE_HEIGHT_PX; the thirteenth fit, not bundled)")
    p.add_argument("--edge-corr", action="store_true",
                   help="fit the correlation of the flow windows' top and bottom edge errors by kind of window (plain, "
                        "crowded) and the person's image height (the rendered window grows or shrinks as a whole; the "
                        "fourteenth fit, not bundled)")
    p.add_argument("--border", action="store_true",
                   help="fit the flow windows of a person cut by the image border that stop short of it: how often "
                        "and for how long by side and image velocity, the gap, and their flow falling behind the "
                        "person's (the fifteenth fit, not bundled)")
    p.add_argument("--flow-by-kind", action="store_true",
                   help="fit the flow windows' flow errors per kind of window too (plain, crowded, cut by a box, cut by "
                        "the image border: the rendered crowded windows' flow falls far shorter; the sixteenth fit, not "
                        "bundled)")
    p.add_argument("--flow-persist", action="store_true",
                   help="fit the flow windows' flow errors as persisting on two time scales (a slow and a fast part: "
                        "the rendered flow detector's long shortfalls; the eleventh fit, not bundled)")
    p.add_argument("--quiet", action="store_true", help="no progress bar while rendering")


def parse_seeds(text: str) -> list[int]:
    from trackroom.errors import CommandError

    seeds = []
    try:
        for part in text.split(","):
            a, _, b = part.strip().partition("-")
            seeds += list(range(int(a), int(b) + 1)) if b else [int(a)]
    except ValueError:
        raise CommandError(f"--seeds: expected seeds like 100,101 or 100-104, got {text!r}") from None
    if not seeds:
        raise CommandError("--seeds: no seeds given")
    return seeds


def find_recordings(paths) -> list:
    """Rendered recording folders under ``paths`` (a folder with manifest.json is one)."""
    from pathlib import Path

    from trackroom.errors import CommandError

    out = []
    for p in map(Path, paths):
        if not p.is_dir():
            raise CommandError(f"{p}: not a folder")
        found = [p] if (p / "manifest.json").is_file() else sorted(m.parent for m in p.rglob("manifest.json"))
        if not found:
            raise CommandError(f"{p}: holds no recording (no manifest.json)")
        out += found
    return out


def run(args) -> int:
    import tempfile
    from pathlib import Path

    import pandas as pd

    from trackroom.cli.commands.generate import check_duration, generate_to
    from trackroom.dataset import read_recording
    from trackroom.errors import CommandError
    from trackroom.scenes.loader import load_scene
    from trackroom.sim import perception_fit as pf
    from trackroom.sim.simulate import simulate

    if args.rounds < 0:
        raise CommandError(f"--rounds must be 0 or more, got {args.rounds}")
    if args.draws < 1:
        raise CommandError(f"--draws must be 1 or more, got {args.draws}")
    folders = find_recordings(args.recordings) if args.recordings else []
    if args.render:
        check_duration(args.duration)

        for name in args.render:
            scene = load_scene(name, args.overrides)
            for seed in parse_seeds(args.seeds):
                out = Path(args.rec_dir) / f"{scene.name}_s{seed}"
                if not (out / "manifest.json").is_file():
                    generate_to(scene, seed, args.duration, "rendered", out, progress=not args.quiet,
                                command=getattr(args, "_command", None))
                folders.append(out)
    if not folders:
        raise CommandError("no recordings: give rendered recording folders or --render SCENE")
    measured, names = [], []
    for d in folders:
        rec = read_recording(d)
        if rec.meta.get("sensing") != "rendered":
            raise CommandError(f"{d}: a {rec.meta.get('sensing')} recording; the model is fitted to rendered ones")
        scene = load_scene(d / "scene.toml")
        feats = pf.scene_features(scene, int(rec.meta["seed"]), float(rec.meta["duration"]))
        measured.append((d, rec, scene, feats, pf.measure(rec, scene, feats)))
        names.append(f"{rec.meta['scene']} seed {rec.meta['seed']} ({float(rec.meta['duration']):g} s)")
        print(f"measured {d}", flush=True)
    rendered = pf.merge_stats([m[-1] for m in measured])
    model = pf.fit(rendered, names, crowded=not args.pooled_edges, flow_persist=args.flow_persist, by_height=args.by_height,
                   edge_corr=args.edge_corr, border=args.border,
                   flow_by_kind=args.flow_by_kind)
    if args.only:
        from trackroom.sim.perception_model import DETECTORS, ModelError, load_model

        only = [k.strip() for k in args.only.split(",") if k.strip()]
        unknown = [k for k in only if k not in DETECTORS]
        if unknown or not only:
            raise CommandError(f"--only: unknown detector(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(DETECTORS)}")
        try:
            base = load_model(args.base)
        except ModelError as e:
            raise CommandError(str(e)) from None
        # the detectors are fitted independently (each its own statistics and corrections): the
        # others are the base model's as they were
        model.fitted_on = list(dict.fromkeys(base.fitted_on + names))

    def keep_others(model):
        if args.only:  # the other detectors stay the base model's through the correction rounds too
            model.detectors = {k: model.detectors[k] if k in only else base.detectors[k] for k in model.detectors}
        return model

    model = keep_others(model)

    def simulated(model, path):
        """The model's analytic statistics on the same scenes and seeds (the model saved at ``path``,
        which the scenes' ``sensors.perception`` names)."""
        model.save(path)
        out = []
        for d, rec, scene, feats, _ in measured:
            for draw in range(args.draws):  # draw 0: the recording of the seed; more redraw the camera streams
                sim = simulate(_with_model(scene, path), int(rec.meta["seed"]), float(rec.meta["duration"]),
                               perception_draw=draw)
                out.append(pf.measure(sim, scene, feats))
        return pf.merge_stats(out)

    with tempfile.TemporaryDirectory() as tmp:  # the rounds' models: --out gets only the final one
        trial = Path(tmp) / "model.json"
        for i in range(args.rounds):  # fitting by simulation: rates corrected until analytic matches rendered
            model = keep_others(pf.correct(model, rendered, simulated(model, trial)))
            print(f"correction round {i + 1} of {args.rounds} done", flush=True)
    analytic = simulated(model, args.out)  # writes the final model
    print(f"{args.out}: perception model fitted on {len(names)} rendered recording(s)")
    print(parameter_text(model))
    r = pf.summary(rendered)
    a = pf.summary(analytic)
    table = pd.concat([r.assign(mode="rendered"), a.assign(mode="analytic")], ignore_index=True)
    table = table[table["candidates"] > 0].sort_values(["detector", "mode"], ascending=[True, False], kind="mergesort")
    table = table[["detector", "mode", *pf.SUMMARY_COLUMNS]]
    if args.table:
        from trackroom.dataset import atomic_write

        atomic_write(Path(args.table), lambda p: table.to_csv(p, index=False, float_format="%.6g"))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.round(3).to_string(index=False, na_rep="-"))
    return 0


def _with_model(scene, path):
    """``scene`` with ``sensors.perception`` set to the model file ``path``."""
    import dataclasses

    return dataclasses.replace(scene, sensors=dataclasses.replace(scene.sensors, perception=str(path)))


def parameter_text(model) -> str:
    """The fitted parameters, one block per detector."""
    lines = []
    for name, m in model.detectors.items():
        if m.detect.n is not None and m.detect.n.sum() == 0:
            lines.append(f"  {name}: no data (defaults)")
            continue
        errs = ", ".join(f"{k} {q.bias:+.3g}/{q.sigma:.3g}" for k, q in m.errors.items())
        lines.append(f"  {name}: detect {float(m.detect.p.min()):.2f}-{float(m.detect.p.max()):.2f} over "
                     f"{int(m.detect.n.sum()) if m.detect.n is not None else 0} candidates, "
                     + (f"miss stay {m.miss_stay:.3f}" if m.miss_stay is not None else f"miss correlation {m.rho:.3f}") + ", "
                     f"merge {float(m.merge.p.min()):.2f}-{float(m.merge.p.max()):.2f}"
                     + (f" (stay {m.merge_stay:.3f})" if m.merge_stay is not None else "") + f", label {m.label:.3f}, "
                     f"clutter {m.clutter:.3f}/frame" + (f" (lives {m.clutter_frames:.1f} frames), id restart {m.restart:.4f}/frame, "
                                                          f"swap at split {m.swap:.2f}" if name == "windows" else ""))
        lines.append(f"      errors (bias/sigma): {errs}")
        if m.edge_corr is not None:
            c = m.edge_corr
            lines.append("      top/bottom edge correlation by image height (bins at "
                         + ", ".join(f"{h:g}" for h in c.heights) + " px): "
                         + "; ".join(f"{k} " + " ".join(f"{r:+.2f}" for r in v) for k, v in c.rho.items()))
        if m.border is not None:
            b = m.border
            lines.append(f"      border-cut windows stopping short: P {float(b.short.p.min()):.3f}-{float(b.short.p.max()):.3f} "
                         f"(stay {b.stay:.3f}), flow gain left {b.gain[0]:.2f} right {b.gain[1]:.2f}")
        if m.tail is not None:
            t = m.tail
            starts = " ".join(f"{v:.2g}" for v in t.start.p.ravel())
            lines.append(f"      drift episodes: start per detection (whole/cut x alone/near) {starts}, {t.frames:.2f} frames, "
                         f"peak {t.size.bias:.3f} m median / {float(t.size.q[-1]):.3f} m max, followed by a miss {t.miss:.2f}")
    return "\n".join(lines)
