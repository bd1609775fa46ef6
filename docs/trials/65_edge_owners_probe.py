"""edgemeas.py OUT.csv DIR...: every shared merged-window edge (edge_share applies: the edge inside the
outermost member's predicted edge), with whose true person's cylinder edge is nearest it."""
import sys, inspect, numpy as np, pandas as pd
from trackroom.estimators import tp_joint, tp_geometry as geo
from trackroom.dataset import read_recording
from scripts.experiment_tsutsui import run_target, distances_at
JT = tp_joint.JointTracker
orig = JT.edge_owners
LOG = []
def edge_owners(self, ps, u, side, outer):
    w = orig(self, ps, u, side, outer)
    if w is None or len(ps) < 2 or w[outer] == 1.0 and (u - float(ps[outer].win[side])) * (1.0 if side else -1.0) >= 0.0:
        return w
    f = inspect.currentframe().f_back
    while "plans" not in f.f_locals:
        f = f.f_back
    L = f.f_locals
    c, mem, tracks, plans = L["c"], L["mem"], L["tracks"], L["plans"]
    own_else = {m[0] for c2, (ex, _) in plans.items() if c2 != c for m in ex.values() if len(m) == 1}
    o = mem[outer]
    LOG.append(dict(t=round(self.clock, 3), cam=c, side=side, u=u, n=len(ps), tids=[tracks[i].tid for i in mem], outer=outer,
                    pred=[float(p.win[side]) for p in ps], share=[float(x) for x in w], walks=o in own_else,
                    pslow=self.p_slow(ps[outer]), mu=tracks[o].mu, spd=float(np.hypot(*tracks[o].s[2:])), P=self.Ps[c],
                    H=self.cfg.height, R=self.cfg.radius))
    return w
JT.edge_owners = edge_owners
rows = []
for d in sys.argv[2:]:
    LOG.clear()
    rec = read_recording(d)
    res = run_target(rec)
    it = res.internal
    ppl = rec.truth.people
    for r in LOG:
        pos = []
        for tid in r["tids"]:
            q = it[(it.track_id == tid) & (np.abs(it.t - r["t"]) < 0.05)]
            pos.append((float(q.x.iloc[0]), float(q.y.iloc[0])) if len(q) else (np.nan, np.nan))
        if not np.isfinite(pos).all():
            continue
        names, D = distances_at(ppl, [r["t"]] * len(pos), pos)
        who = [names[k] for k in D.argmin(1)]
        if len(set(who)) < len(who):
            continue
        from scripts.experiment_tsutsui import people_at
        now = people_at(ppl, np.array([r["t"]])).set_index("person_id")
        tedge = [float(geo.cylinder_window(r["P"], np.array([now.loc[w, "x"], now.loc[w, "y"]]), r["H"], r["R"])[r["side"]]) for w in who]
        owner = int(np.argmin([abs(r["u"] - e) for e in tedge]))
        rows.append(dict(rec=d, t=r["t"], cam=r["cam"], side=r["side"], n=r["n"], u=round(r["u"], 1), pred=np.round(r["pred"], 1).tolist(),
                         true=np.round(tedge, 1).tolist(), share_outer=round(r["share"][r["outer"]], 3), outer_owns=owner == r["outer"],
                         walks=r["walks"], pslow=round(r["pslow"], 3), mu=round(r["mu"], 3), spd=round(r["spd"], 2),
                         inside=round(abs(r["u"] - r["pred"][r["outer"]]), 1)))
    print(d, len(LOG), flush=True)
pd.DataFrame(rows).to_csv(sys.argv[1], index=False)
