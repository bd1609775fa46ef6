"""dupmu.py OUT.csv DIR...: every confirmed duplicate drop (single-target run) with both tracks' mu,
seen, n_used, and explain_tp_ends' class of the drop."""
import sys, numpy as np, pandas as pd
from trackroom.estimators import tp_joint
from trackroom.dataset import read_recording
import scripts.explain_tp_ends as ete
from scripts.experiment_tsutsui import run_target
JT = tp_joint.JointTracker
orig = JT.prune
LOG = []
def prune(self, tracks, keep, inside_room):
    byid = {tr.tid: tr for tr in tracks}
    snap = {tr.tid: (tr.mu, tr.seen, tr.n_used, float(np.hypot(*tr.s[2:])), tr.s.copy(), tr.S.copy(), tr.prior) for tr in tracks}
    out = orig(self, tracks, keep, inside_room)
    for tr, why, other in self.ends:
        if why == "duplicate":
            LOG.append(dict(t=round(self.clock, 3), tid=tr.tid, other=other, mu=snap[tr.tid][0], seen=snap[tr.tid][1], used=snap[tr.tid][2], spd=snap[tr.tid][3],
                            dd=float(np.hypot(*(snap[tr.tid][4][:2] - snap[other][4][:2]))),
                            dv=float(np.hypot(*(snap[tr.tid][4][2:] - snap[other][4][2:]))),
                            sd_pos=float(np.sqrt(np.trace((snap[tr.tid][5] + snap[other][5])[:2, :2]) / 2)),
                            ddp=float(np.hypot(*(snap[tr.tid][6][0][:2] - snap[other][6][0][:2]))) if snap[tr.tid][6] is not None and snap[other][6] is not None else np.nan,
                            mu_o=snap[other][0], seen_o=snap[other][1], used_o=snap[other][2], spd_o=snap[other][3], keep=keep))
    return out
JT.prune = prune
rows = []
for d in sys.argv[2:]:
    LOG.clear()
    rec = read_recording(d)
    res = run_target(rec)
    cls = {(round(r["t"], 1), r["track"]): r for r in ete.ends_against_truth(rec.truth.people, res.internal, res.ends)}
    for r in LOG:
        c = cls.get((round(r["t"], 1), r["tid"]), {})
        r.update(rec=d, cls=c.get("class"), who=c.get("who"), speed=c.get("speed"), dist=c.get("dist"))
        from scripts.experiment_tsutsui import people_at
        now = people_at(rec.truth.people, np.array([r["t"]])).set_index("person_id")
        it = res.internal
        for key, tid in (("drop", r["tid"]), ("kept", r["other"])):
            q = it[(it.track_id == tid) & (np.abs(it.t - r["t"]) < 0.05)]
            if key == "drop":
                e = res.ends[(res.ends.track_id == tid) & (np.abs(res.ends.t - r["t"]) < 0.05)]
                q = e if len(e) else q
            if len(q):
                dd = np.hypot(now.x - float(q.x.iloc[0]), now.y - float(q.y.iloc[0]))
                r[key + "_near"] = dd.idxmin(); r[key + "_d"] = round(float(dd.min()), 2)
                r[key + "_dtgt"] = round(float(dd.get("target", np.nan)), 2); r[key + "_ddis"] = round(float(dd.get("distractor", np.nan)), 2)
        if "target" in now.index and "distractor" in now.index:
            r["td"] = round(float(np.hypot(*(now.loc["target", ["x", "y"]] - now.loc["distractor", ["x", "y"]]))), 2)
    rows += LOG
    print(d, len(LOG), flush=True)
pd.DataFrame(rows).to_csv(sys.argv[1], index=False)
