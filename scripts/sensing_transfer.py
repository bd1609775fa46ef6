"""Do analytic figures transfer to rendered ones? Every estimator on its scenes, same scenes and seeds.

    python -m scripts.sensing_transfer --rendered DIR [--seeds 300-304] [--render] [--csv OUT]

DIR holds rendered recordings as DIR/{overhead_lab,overhead_lab_privacy,occlusion_lab,bearing_hall}/
s{SEED} (``--render`` makes the missing ones: 30 s each, occlusion_lab 35 s; the privacy variant is
overhead_lab with every camera's ``privacy = true``). For each recording the analytic twin is
simulated from the rendered recording's own resolved scene and seed, once with the fitted
perception model (``sensors.perception = "fitted"``, the default) and once with ``"ideal"`` (the
old analytic sensing: perfect labels, no merges, per-person window ids), and each estimator runs
on all three:

  ekf           overhead_lab                 MOTA, IDF1, RMSE (m)
  hmm_matcher   overhead_lab, privacy        ID accuracy (phone claims), MOTA, RMSE
  target_planes occlusion_lab, the target    identity held (``scripts.experiment_tsutsui``: a noisy
                                             click starts it), RMSE with >= 2 tracking cameras
  target_planes occlusion_lab, multi-person  MOTA and IDF1 against the movers, RMSE
  qp_smoother   bearing_hall                 RMSE (m), MOTA

Figures are means over the seeds. Targets (issue 11): identity / ID accuracy within 3 points,
MOTA within 0.05, RMSE ratio rendered / analytic within 0.67-1.5. The evaluation seeds (300-304
by default) are never used to fit the perception model (fitted on 100-105) or to develop it.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file

SCENES = {  # folder -> (bundled scene, overrides, duration)
    "overhead_lab": ("overhead_lab", [], 30.0),
    "overhead_lab_privacy": ("overhead_lab", ["cameras.*.privacy=true"], 30.0),
    "occlusion_lab": ("occlusion_lab", [], 35.0),
    "bearing_hall": ("bearing_hall", [], 30.0),
}
# (case, folder, figures): the figures each case reports, identity first
CASES = [
    ("ekf", "overhead_lab", ("idf1", "mota", "rmse")),
    ("hmm_matcher", "overhead_lab", ("id_accuracy", "mota", "rmse")),
    ("hmm_matcher", "overhead_lab_privacy", ("id_accuracy", "mota", "rmse")),
    ("target_planes (target)", "occlusion_lab", ("identity_held", None, "rmse_2plus")),
    ("target_planes (multi)", "occlusion_lab", ("idf1", "mota", "rmse")),
    ("qp_smoother", "bearing_hall", (None, "mota", "rmse")),
]
MODES = ("analytic", "ideal", "rendered")
MODEL = ["fitted"]  # the analytic twin's perception model (--model)


def recording_for(folder: Path, mode: str, rendered_rec, draw: int = 0):
    """The rendered recording itself, or its analytic twin (same resolved scene and seed; ``draw``
    > 0 redraws the analytic camera tables' random streams, ``simulate(perception_draw=...)``)."""
    from trackroom.scenes.loader import load_scene

    if mode == "rendered":
        # what a rendered recording declares now: the fitted model's measured noise (recordings
        # written before the model declared the scene's figures)
        from trackroom.sim.simulate import calibration_noise

        scene = load_scene(folder / "scene.toml")
        rendered_rec.calibration.noise = calibration_noise(scene, "rendered")
        return rendered_rec
    from trackroom.sim.simulate import simulate

    scene = load_scene(folder / "scene.toml", [f"sensors.perception={MODEL[0] if mode == 'analytic' else 'ideal'}"])
    return simulate(scene, int(rendered_rec.meta["seed"]), float(rendered_rec.meta["duration"]), perception_draw=draw)


def figures(case: str, rec, tp_params: dict | None = None) -> dict:
    from scripts import experiment_tsutsui as ts
    from trackroom.estimators import get
    from trackroom.estimators.target_planes import TargetPlanes
    from trackroom.metrics.score import evaluate
    from trackroom.scenes.loader import load_scene

    if case == "target_planes (target)":
        return ts.single_target_metrics(rec, ts.run_target(rec, tp_params))
    if case == "target_planes (multi)":
        kw = {**ts.estimator_config(rec), **(tp_params or {})}
        tracks = TargetPlanes(multi_person=True, **kw).estimate(rec.observations, rec.calibration)
        scene = load_scene(rec.meta["scene"])
        return evaluate(ts.movers_only(rec, scene), tracks, gate=1.0).metrics()
    tracks = get(case)().estimate(rec.observations, rec.calibration)
    return evaluate(rec, tracks).metrics()


def ensure_rendered(root: Path, folder: str, seed: int, render: bool) -> Path:
    out = root / folder / f"s{seed}"
    if (out / "manifest.json").is_file():
        return out
    if not render:
        raise SystemExit(f"{out}: no rendered recording (run with --render to make it)")
    from trackroom.cli.commands.generate import generate_to
    from trackroom.scenes.loader import load_scene

    name, overrides, duration = SCENES[folder]
    generate_to(load_scene(name, overrides), seed, duration, "rendered", out, progress=True)
    return out


def main(argv=None) -> int:
    from trackroom.cli.commands.calibrate_sensing import parse_seeds
    from trackroom.dataset import read_recording

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rendered", required=True, help="folder of rendered recordings (see above)")
    ap.add_argument("--seeds", default="300-304", help="evaluation seeds (default 300-304)")
    ap.add_argument("--render", action="store_true", help="render the missing recordings")
    ap.add_argument("--csv", help="write every run's figures here")
    ap.add_argument("--cases", help="comma-separated case names or scene folders to run (default all)")
    ap.add_argument("--draws", type=int, default=1, help="perception draws of the fitted analytic twin per seed "
                    "(default 1: the recording's own; more average over redrawn camera streams and show their spread)")
    ap.add_argument("--model", default="fitted", help="perception model file of the analytic twin (default: the bundled one)")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                    help="a target_planes Config value (JSON) for both modes, e.g. hold_s=4 (repeatable)")
    a = ap.parse_args(argv)
    MODEL[0] = a.model
    from scripts.experiment_tsutsui import parse_params

    tp_params = parse_params(a.param)
    seeds = parse_seeds(a.seeds)
    root = Path(a.rendered)
    rows = []
    cases = [c for c in CASES if not a.cases or c[0] in a.cases.split(",") or c[1] in a.cases.split(",")]
    for folder in dict.fromkeys(c[1] for c in cases):
        for seed in seeds:
            d = ensure_rendered(root, folder, seed, a.render)
            rendered = read_recording(d)
            for mode in MODES:
                for draw in range(a.draws if mode == "analytic" else 1):
                    rec = recording_for(d, mode, rendered, draw)
                    for case, f, _ in cases:
                        if f != folder:
                            continue
                        m = figures(case, rec, tp_params)
                        rows.append({"case": case, "scene": folder, "seed": seed, "mode": mode, "draw": draw,
                                     **{k: m.get(k, np.nan) for k in ("identity_held", "idf1", "id_accuracy", "mota", "rmse",
                                                                       "rmse_2plus")}})
            print(f"done {folder} seed {seed}", file=sys.stderr, flush=True)
    df = pd.DataFrame(rows)
    if a.csv:
        df.to_csv(a.csv, index=False, float_format="%.6g")
    from trackroom.metrics.aggregate import markdown_table

    t = transfer_table(df, cases)
    print(markdown_table(list(t.columns), t.astype(str).values.tolist()))
    return 0


def transfer_table(df: pd.DataFrame, cases) -> pd.DataFrame:
    """One row per case and figure: mean per mode, the rendered - analytic gap and the verdict.
    With several analytic draws per seed (column ``draw``) the analytic figure is the mean over
    seeds and draws, and a column gives the range of the per-draw means over the seeds."""
    out = []
    if "draw" not in df:
        df = df.assign(draw=0)
    draws = int(df["draw"].max()) + 1 if len(df) else 1
    for case, folder, (ident, mota, rmse) in cases:
        g = df[(df["case"] == case) & (df["scene"] == folder)]
        mean = g.groupby("mode").mean(numeric_only=True)
        per_draw = g[g["mode"] == "analytic"].groupby("draw").mean(numeric_only=True)
        if not len(mean):
            continue
        label = f"{case}, {folder}"
        for kind, col in (("identity", ident), ("MOTA", mota), ("RMSE", rmse)):
            if col is None:
                continue
            a, i, r = (float(mean.loc[m, col]) if m in mean.index else np.nan for m in MODES)
            if kind == "RMSE":
                gap, ok = r / a, 0.67 <= r / a <= 1.5
                gap_ideal = r / i
                show = lambda x: f"{x:.3f} m"  # noqa: E731
                gap_text, ideal_text = f"x{gap:.2f}", f"x{gap_ideal:.2f}"
            else:
                gap, ok = r - a, abs(r - a) <= (0.03 if kind == "identity" else 0.05)
                show = lambda x: f"{x:.3f}"  # noqa: E731
                gap_text, ideal_text = f"{gap:+.3f}", f"{r - i:+.3f}"
            out.append({"estimator, scene": label, "figure": f"{kind} ({col})", "analytic (fitted)": show(a),
                        "rendered": show(r), "gap": gap_text, "target met": "yes" if ok else "NO",
                        "analytic (ideal)": show(i), "gap to ideal": ideal_text, "seeds": int(g["seed"].nunique()),
                        **({"analytic draws (min-max)": f"{per_draw[col].min():.3f}-{per_draw[col].max():.3f}",
                            "gap over draws": spread(r, per_draw[col], kind)} if draws > 1 else {})})
    return pd.DataFrame(out)


def spread(r: float, a: pd.Series, kind: str) -> str:
    """The gap's range over the analytic draws (each draw's mean over the seeds)."""
    g = r / a if kind == "RMSE" else r - a
    return f"x{g.min():.2f}-x{g.max():.2f}" if kind == "RMSE" else f"{g.min():+.3f} to {g.max():+.3f}"


if __name__ == "__main__":
    sys.exit(main())
