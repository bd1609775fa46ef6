"""A probe (issue 12's seventy-fifth session, at b785c0b; not part of the package):

    MUJOCO_GL=egl python docs/trials/75_edge_correlation_probe.py 100 101 ... 109   # REC/seed_N, rendered

The own windows' (plain and crowded, one person each) edge errors of ``perception_fit.measure``,
by the person's height bin (``analytic_detectors.height_bin``), rendered against the analytic twin
(draw 0, the bundled model): the Spearman correlation of the top and bottom edges' errors, and
each edge's lag-1 Spearman autocorrelation (the same camera and person on consecutive frames).
The measurement keeps the errors but not which window they came from, so the probe wraps
``perception_fit.edge_tables``, called once per own window just before its errors are filed, to
record (frame, person, tables); a frame number lower than the last one starts the next camera."""
import os
import sys, numpy as np
from pathlib import Path
from trackroom.dataset import read_recording
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate
from trackroom.sim import perception_fit as pf
from trackroom.sim.analytic_detectors import height_bin

orig = pf.edge_tables
cap = []
def wrap(g, e, frac, moving, f, members, *a, **k):
    t = orig(g, e, frac, moving, f, members, *a, **k)
    cap.append((f, members[0], t, float(e[f, members[0], 3] - e[f, members[0], 2])))
    return t
pf.edge_tables = wrap

def rows(stats, captured):
    s = stats["windows"]
    out = []
    for tag in ("", "_crowded"):
        ent = [c for c in captured if c[2] == tag]
        E = np.column_stack([s.errors[n + tag] for n in ("u_left", "u_right", "v_top", "v_bottom")])
        assert len(ent) == len(E), (len(ent), len(E))
        cam = np.cumsum([0] + [1 if ent[i][0] < ent[i - 1][0] else 0 for i in range(1, len(ent))])
        for i, (f, p, _, h) in enumerate(ent):
            out.append((cam[i], f, p, tag, h, *E[i]))
    return out

res = {"rendered": [], "analytic": []}
for n in map(int, sys.argv[1:]):
    d = Path(os.environ.get("REC", "/work/rec/occ_r")) / f"seed_{n}"
    rec = read_recording(d); scene = load_scene(d / "scene.toml")
    feats = pf.scene_features(scene, n, 35.0)
    for mode in res:
        cap.clear()
        r = rec if mode == "rendered" else simulate(scene, n, 35.0, perception_draw=0)
        st = pf.measure(r, scene, feats)
        res[mode] += [(n,) + x for x in rows(st, list(cap))]
for mode, R in res.items():
    A = np.array([(x[0], x[1], x[2], x[3], 0 if x[4] == "" else 1, x[5], *x[6:]) for x in R], float)
    seed, cam, f, p, crowd, h, ul, ur, vt, vb = A.T
    hb = height_bin(h)
    for k in range(3):
        on = (hb == k)
        from scipy.stats import spearmanr
        c_tb = spearmanr(vt[on], vb[on])[0]
        # lag-1: same seed, cam, person, consecutive frames
        key = {(int(seed[i]), int(cam[i]), int(p[i]), int(f[i])): i for i in np.nonzero(on)[0]}
        pairs = [(i, key[(s_, c_, p_, f_ + 1)]) for (s_, c_, p_, f_), i in key.items() if (s_, c_, p_, f_ + 1) in key]
        I, J = np.array(pairs).T
        def r1(x):  # rank correlation of consecutive errors
            return spearmanr(x[I], x[J])[0]
        print(f"{mode:8s} h{k} n {on.sum():5d} corr(top,bottom) {c_tb:+.2f}  lag1 top {r1(vt):+.2f} bottom {r1(vb):+.2f} left {r1(ul):+.2f} right {r1(ur):+.2f}  pairs {len(I)}")
