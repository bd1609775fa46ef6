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


def recording_for(folder: Path, mode: str, rendered_rec):
    """The rendered recording itself, or its analytic twin (same resolved scene and seed)."""
    from trackroom.scenes.loader import load_scene

    if mode == "rendered":
        # what a rendered recording declares now: the fitted model's measured noise (recordings
        # written before the model declared the scene's figures)
        from trackroom.sim.simulate import calibration_noise

        scene = load_scene(folder / "scene.toml")
        rendered_rec.calibration.noise = calibration_noise(scene, "rendered")
        return rendered_rec
    from trackroom.sim.simulate import simulate

    scene = load_scene(folder / "scene.toml", [f"sensors.perception={'fitted' if mode == 'analytic' else 'ideal'}"])
    return simulate(scene, int(rendered_rec.meta["seed"]), float(rendered_rec.meta["duration"]))


def figures(case: str, rec) -> dict:
    from scripts import experiment_tsutsui as ts
    from trackroom.estimators import get
    from trackroom.estimators.target_planes import TargetPlanes
    from trackroom.metrics.score import evaluate
    from trackroom.scenes.loader import load_scene

    if case == "target_planes (target)":
        res = TargetPlanes(initial_xy=ts.click(rec), **ts.estimator_config(rec)).run(rec.observations, rec.calibration)
        return ts.single_target_metrics(rec, res)
    if case == "target_planes (multi)":
        tracks = TargetPlanes(multi_person=True, **ts.estimator_config(rec)).estimate(rec.observations, rec.calibration)
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
    ap.add_argument("--cases", help="comma-separated case names to run (default all)")
    a = ap.parse_args(argv)
    seeds = parse_seeds(a.seeds)
    root = Path(a.rendered)
    rows = []
    cases = [c for c in CASES if not a.cases or c[0] in a.cases.split(",") or c[1] in a.cases.split(",")]
    for folder in dict.fromkeys(c[1] for c in cases):
        for seed in seeds:
            d = ensure_rendered(root, folder, seed, a.render)
            rendered = read_recording(d)
            for mode in MODES:
                rec = recording_for(d, mode, rendered)
                for case, f, _ in cases:
                    if f != folder:
                        continue
                    m = figures(case, rec)
                    rows.append({"case": case, "scene": folder, "seed": seed, "mode": mode, **{k: m.get(k, np.nan) for k in
                                 ("identity_held", "idf1", "id_accuracy", "mota", "rmse", "rmse_2plus")}})
            print(f"done {folder} seed {seed}", file=sys.stderr, flush=True)
    df = pd.DataFrame(rows)
    if a.csv:
        df.to_csv(a.csv, index=False, float_format="%.6g")
    from trackroom.metrics.aggregate import markdown_table

    t = transfer_table(df, cases)
    print(markdown_table(list(t.columns), t.astype(str).values.tolist()))
    return 0


def transfer_table(df: pd.DataFrame, cases) -> pd.DataFrame:
    """One row per case and figure: mean per mode, the rendered - analytic gap and the verdict."""
    out = []
    for case, folder, (ident, mota, rmse) in cases:
        g = df[(df["case"] == case) & (df["scene"] == folder)]
        mean = g.groupby("mode").mean(numeric_only=True)
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
                        "analytic (ideal)": show(i), "gap to ideal": ideal_text, "seeds": int(g["seed"].nunique())})
    return pd.DataFrame(out)


if __name__ == "__main__":
    sys.exit(main())
