"""Figure like Tsutsui et al. Figs. 11-12: the target's estimated top-down trace against the truth
on ``occlusion_lab``, and per camera the frames where it was tracking / lost / unreliable.

    python scripts/fig_tsutsui.py [--sensing analytic|rendered] [--duration 60] [--seed 0] [--out docs/img/tsutsui_trace.png]
    python scripts/fig_tsutsui.py --recording DIR --out docs/img/tsutsui_trace_rendered.png   # a saved recording
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_tsutsui import TARGET, run  # noqa: E402

from trackroom.topdown import draw_floorplan  # noqa: E402

STATUS_COLOURS = {"tracking": "#2ca02c", "merged": "#1f77b4", "unreliable": "#ff7f0e", "lost": "#d62728"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sensing", default="analytic", choices=["analytic", "rendered"])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="docs/img/tsutsui_trace.png")
    ap.add_argument("--recording", help="a saved recording folder instead of a simulation")
    a = ap.parse_args(argv)
    saved = None
    if a.recording:
        from trackroom.dataset import read_recording, recording_folders

        saved = read_recording(recording_folders([a.recording], ap.prog)[0])  # a missing folder named, no traceback
    rec, res, m = run(a.sensing, a.duration, a.seed, recording=saved)
    fp = rec.calibration.floorplan
    tr = res.tracks
    ppl = rec.truth.people

    fig = plt.figure(figsize=(12, 6.5))
    ax = fig.add_axes([0.06, 0.08, 0.45, 0.8])
    draw_floorplan(ax, fp)
    for pid, g in ppl.groupby("person_id"):
        if pid == TARGET:
            ax.plot(g.x, g.y, "k-", lw=1.0, label="target (truth)")
        elif g[["x", "y"]].diff().abs().sum().sum() < 0.1:
            ax.plot(g.x.iloc[0], g.y.iloc[0], "s", color="0.4", ms=7)
        else:
            ax.plot(g.x, g.y, ":", color="0.5", lw=1.0, label=f"{pid} (truth)")
    sc = ax.scatter(tr.x, tr.y, c=tr.n_cameras, cmap="viridis", s=8, vmin=0, vmax=len(rec.calibration.cameras_of_kind("oblique")), label="estimate")
    fig.colorbar(sc, ax=ax, fraction=0.04, label="reliable tracking cameras")
    for name, cam in rec.calibration.cameras_of_kind("oblique").items():
        ax.plot(*cam.position[:2], "^", color="tab:blue")
        ax.annotate(name, cam.position[:2], fontsize=8)
    ax.set_aspect("equal")
    ax.set_title(
        f"occlusion_lab ({m['sensing']}, seed {m['seed']}, {m['duration']:.0f} s): identity {100 * m['identity_held']:.1f}%, "
        f"RMSE {m['rmse_2plus']:.2f} m (>=2 cams), {m['rmse_1']:.2f} m (1 cam)",
        fontsize=9,
    )
    ax.legend(fontsize=7, loc="lower right")

    st = res.status
    cams = sorted(st.camera.unique())
    ax2 = fig.add_axes([0.64, 0.55, 0.34, 0.38])
    for i, c in enumerate(cams):
        s = st[st.camera == c]
        for status, col in STATUS_COLOURS.items():
            t = s.t[s.status == status].to_numpy()
            ax2.scatter(t, np.full(len(t), i), c=col, s=4, marker="|", label=status if i == 0 else None)
    ax2.set_yticks(range(len(cams)), cams)
    ax2.set_xlabel("t (s)")
    ax2.set_title("camera status for the target", fontsize=9)
    ax2.legend(fontsize=7, loc="upper right", ncol=3)

    ax3 = fig.add_axes([0.64, 0.08, 0.34, 0.35])
    t = tr.t.to_numpy()
    g = ppl[ppl.person_id == TARGET]
    k = np.clip(np.searchsorted(g.t.to_numpy(), t - 1e-9), 0, len(g) - 1)
    err = np.hypot(tr.x.to_numpy() - g.x.to_numpy()[k], tr.y.to_numpy() - g.y.to_numpy()[k])
    ax3.plot(t, err, "k-", lw=0.8)
    ax3.set_yscale("log")
    ax3.set_xlabel("t (s)")
    ax3.set_ylabel("position error (m)")
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    fig.savefig(a.out, dpi=110)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
