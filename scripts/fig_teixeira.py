"""Reproduce Teixeira et al.'s simulation study (Figs. 8 and 9) with the ``hmm_matcher`` estimator.

For each sensor setup (ideal sensors, regular camera, privacy camera), each number of people
(1-10 in the 10 m x 10 m ``overhead_lab``) and each seed: simulate 60 s (analytic sensing), run
the matcher, score it with ``metrics.score.evaluate`` (identification accuracy, eq. 22, both
ways of counting people nobody identified: ``id_accuracy`` over the claims made, and
``id_accuracy_all`` over the appearances of people who carry a phone). Also measured:

- the mean inter-ambiguity time: the mean duration (s) of the lazy tracker's piecewise-
  unambiguous segments in that run (Fig. 9's abscissa);
- with ``--phoneless``: runs with one third of the people carrying no phone, and the fraction of
  frames in which a phoneless person (the truth person the CLEAR MOT matching paired with a
  track) is claimed as some phone's carrier.

Writes ``docs/img/teixeira_runs.csv`` (one row per run), ``docs/img/teixeira_fig8.png``,
``docs/img/teixeira_fig9.png`` and prints Markdown tables.

    python scripts/fig_teixeira.py --seeds 10 --jobs 2              # the full study (300 runs)
    python scripts/fig_teixeira.py --counts 10 --seeds 10 --only-phoneless --csv docs/img/teixeira_phoneless.csv
    python scripts/fig_teixeira.py --replot docs/img/teixeira_runs.csv    # redraw only
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MUJOCO_GL", "egl")

SETUPS = {
    # Teixeira sec. "Simulation": (1) ideal noiseless sensors, (2) regular camera with noise,
    # (3) privacy camera: the same noise plus 15 cm quantisation, blind to people standing still
    "ideal": ["sensors.floor_sigma_m=0", "sensors.accel_sigma=0", "sensors.mag_sigma=0", "sensors.gyro_sigma=0",
              "sensors.mag_disturbance_deg=0", "sensors.accel_bias=0", "sensors.pocket_yaw_deg=0",
              "sensors.pocket_tilt_deg=0", "sensors.swing_per_min=0"],
    "regular": [],
    "privacy": ["cameras.*.privacy=true"],
}
LABELS = {"ideal": "ideal sensors", "regular": "regular camera", "privacy": "privacy camera"}
COLORS = {"ideal": "tab:green", "regular": "tab:blue", "privacy": "tab:red"}


def phoneless_claimed(ev) -> tuple[float, float, int]:
    """(pooled fraction, worst person's fraction, frames) of phoneless people's appearances in
    which the track matched to them claims a phone."""
    truth = ev.frames.truth
    nophone = truth[truth["phone_id"].fillna("").astype(str) == ""]
    if not len(nophone):
        return float("nan"), float("nan"), 0
    m = ev.mot.matches[["frame", "person_id", "track_id"]].merge(
        ev.frames.tracks[["frame", "track_id", "phone_id"]], on=["frame", "track_id"], how="left")
    m["claims"] = m["phone_id"].fillna("").astype(str) != ""
    j = nophone[["frame", "person_id"]].merge(m[["frame", "person_id", "claims"]], on=["frame", "person_id"], how="left")
    j["claims"] = j["claims"].fillna(False).astype(bool)
    per = j.groupby("person_id")["claims"].mean()
    return float(j["claims"].mean()), float(per.max()), int(len(j))


def one_run(job: tuple) -> dict:
    setup, n, seed, duration, phoneless, params, scene = job
    from trackroom.estimators.hmm_matcher import HMMMatcher
    from trackroom.metrics.score import evaluate
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    over = SETUPS[setup] + list(scene) + [f"walkers.count={n}"] + ([f"walkers.phoneless={n // 3}"] if phoneless else [])
    rec = simulate(load_scene("overhead_lab", over), seed, duration)
    est = HMMMatcher(**params)
    t0 = time.perf_counter()
    tracks = est.estimate(rec.observations, rec.calibration)
    seconds = time.perf_counter() - t0
    segs = est.track(rec.observations["floor_detections"], rec.calibration, rec.duration)
    info = segs.info
    lengths = (info["end_t"] - info["start_t"]).to_numpy(float) + 1.0 / 20.0
    ev = evaluate(rec, tracks)
    ident = ev.identification
    pooled, worst, frames = phoneless_claimed(ev) if phoneless else (float("nan"), float("nan"), 0)
    return {
        "setup": setup, "people": n, "seed": seed, "phoneless": (n // 3) if phoneless else 0,
        "id_accuracy": ident.id_accuracy if ident else float("nan"),
        "id_accuracy_all": ident.id_accuracy_all if ident else float("nan"),
        "identifications": ident.identifications if ident else 0,
        "mota": ev.mot.mota, "segments": len(info), "inter_ambiguity_s": float(lengths.mean()) if len(lengths) else float("nan"),
        "phoneless_claimed": pooled, "phoneless_claimed_worst": worst, "phoneless_frames": frames,
        "seconds": seconds, "realtime_factor": rec.duration / seconds,
    }


def run_all(jobs: list[tuple], workers: int) -> pd.DataFrame:
    from tqdm import tqdm

    if workers <= 1:
        rows = [one_run(j) for j in tqdm(jobs, desc="runs")]
    else:
        with ProcessPoolExecutor(workers) as pool:
            rows = list(tqdm(pool.map(one_run, jobs), total=len(jobs), desc="runs"))
    return pd.DataFrame(rows)


def plot(df: pd.DataFrame, out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = df[df["phoneless"] == 0]
    paths = []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for s in SETUPS:
        g = d[d["setup"] == s]
        if not len(g):
            continue
        ax.scatter(g["people"] + {"ideal": -0.15, "regular": 0.0, "privacy": 0.15}[s], g["id_accuracy"], s=10,
                   alpha=0.35, color=COLORS[s])
        mean = g.groupby("people")["id_accuracy"].mean()
        ax.plot(mean.index, mean.values, "-o", lw=2.2, color=COLORS[s], label=f"{LABELS[s]} (mean)")
        mean_all = g.groupby("people")["id_accuracy_all"].mean()
        ax.plot(mean_all.index, mean_all.values, "--", lw=1.2, color=COLORS[s])
    ax.plot([], [], "k--", lw=1.2, label="dashed: id_accuracy_all (undetected / unclaimed = wrong)")
    ax.set_xlabel("people in 10 m x 10 m")
    ax.set_ylabel("identification accuracy (eq. 22)")
    ax.set_title("Teixeira Fig. 8: accuracy vs. target density (60 s runs)")
    ax.set_ylim(min(0.5, float(d["id_accuracy_all"].min()) - 0.02), 1.01)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    p = out_dir / "teixeira_fig8.png"
    fig.tight_layout(); fig.savefig(p, dpi=120); plt.close(fig)
    paths.append(p)

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for s in SETUPS:
        g = d[d["setup"] == s]
        if not len(g):
            continue
        ax.scatter(g["inter_ambiguity_s"], g["id_accuracy"], s=12, alpha=0.5, color=COLORS[s], label=LABELS[s])
        # binned means over log-spaced inter-ambiguity times
        bins = np.geomspace(max(g["inter_ambiguity_s"].min(), 0.5), g["inter_ambiguity_s"].max() * 1.001, 8)
        b = pd.cut(g["inter_ambiguity_s"], bins)
        mean = g.groupby(b, observed=True).agg(x=("inter_ambiguity_s", "mean"), y=("id_accuracy", "mean"))
        ax.plot(mean["x"], mean["y"], "-", lw=2, color=COLORS[s])
    ax.set_xscale("log")
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter
    ax.xaxis.set_major_locator(FixedLocator([3, 5, 10, 20, 40, 60]))
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("mean inter-ambiguity time (s): mean lazy-tracker segment length")
    ax.set_ylabel("identification accuracy (eq. 22)")
    ax.set_title("Teixeira Fig. 9: accuracy vs. inter-ambiguity time")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower right")
    p = out_dir / "teixeira_fig9.png"
    fig.tight_layout(); fig.savefig(p, dpi=120); plt.close(fig)
    paths.append(p)
    return paths


def tables(df: pd.DataFrame) -> str:
    out = []
    d = df[df["phoneless"] == 0]
    if len(d):
        g = d.groupby(["setup", "people"]).agg(
            runs=("seed", "size"), acc=("id_accuracy", "mean"), acc_min=("id_accuracy", "min"),
            acc_all=("id_accuracy_all", "mean"), gap=("inter_ambiguity_s", "mean"), rt=("realtime_factor", "median"))
        out.append("| setup | people | runs | id_accuracy mean (min) | id_accuracy_all mean | mean inter-ambiguity time (s) | x real time (median) |")
        out.append("| --- | --- | --- | --- | --- | --- | --- |")
        for (s, n), r in g.iterrows():
            out.append(f"| {LABELS[s]} | {n} | {r.runs} | {r.acc:.3f} ({r.acc_min:.3f}) | {r.acc_all:.3f} | {r.gap:.1f} | {r.rt:.0f} |")
    p = df[df["phoneless"] > 0]
    if len(p):
        g = p.groupby(["setup", "people"]).agg(
            runs=("seed", "size"), acc=("id_accuracy", "mean"), acc_all=("id_accuracy_all", "mean"),
            claimed=("phoneless_claimed", "mean"), worst=("phoneless_claimed_worst", "max"))
        out.append("")
        out.append("| setup (1/3 without phones) | people | runs | id_accuracy mean | id_accuracy_all mean | phoneless frames claimed (pooled mean) | worst phoneless person |")
        out.append("| --- | --- | --- | --- | --- | --- | --- |")
        for (s, n), r in g.iterrows():
            out.append(f"| {LABELS[s]} | {n} | {r.runs} | {r.acc:.3f} | {r.acc_all:.3f} | {r.claimed:.3%} | {r.worst:.3%} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--setups", default="ideal,regular,privacy")
    ap.add_argument("--counts", default="1-10", help="numbers of people: '1-10' or '5,10'")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 per data point (default 10)")
    ap.add_argument("--seed0", type=int, default=0, help="first seed (default 0; development seeds: 100)")
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--phoneless", action="store_true", help="also run with one third of the people without a phone")
    ap.add_argument("--only-phoneless", action="store_true", help="only the phoneless runs")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"), help="folder for the figures")
    ap.add_argument("--csv", default="", help="per-run table (default OUT/teixeira_runs.csv)")
    ap.add_argument("--replot", metavar="CSV", help="only redraw the figures and tables from a per-run CSV")
    ap.add_argument("--set", dest="params", action="append", default=[], metavar="K=V", help="matcher parameter")
    ap.add_argument("--scene", action="append", default=[], metavar="K=V",
                    help="scene override after the setup's (e.g. sensors.pocket_yaw_deg=0)")
    args = ap.parse_args(argv)
    from trackroom.estimators.base import coerce_param
    from trackroom.estimators.hmm_matcher import HMMMatcher

    if args.replot:
        df = pd.read_csv(args.replot)
        for p in plot(df, Path(args.out)):
            print(f"wrote {p}")
        print(tables(df))
        return 0
    params = {k: coerce_param(HMMMatcher, k, v) for k, v in (p.split("=", 1) for p in args.params)}
    if "-" in args.counts:
        lo, hi = map(int, args.counts.split("-"))
        counts = list(range(lo, hi + 1))
    else:
        counts = [int(c) for c in args.counts.split(",")]
    setups = args.setups.split(",")
    jobs = []
    if not args.only_phoneless:
        jobs += [(s, n, seed, args.duration, False, params, args.scene) for s in setups for n in counts for seed in range(args.seed0, args.seed0 + args.seeds)]
    if args.phoneless or args.only_phoneless:
        jobs += [(s, n, seed, args.duration, True, params, args.scene) for s in setups for n in counts if n >= 3 for seed in range(args.seed0, args.seed0 + args.seeds)]
    df = run_all(jobs, args.jobs)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.csv or out / "teixeira_runs.csv", index=False, float_format="%.5g")
    if not args.only_phoneless and len(counts) > 1:
        for p in plot(df, out):
            print(f"wrote {p}")
    print(tables(df))
    return 0


if __name__ == "__main__":
    sys.exit(main())
