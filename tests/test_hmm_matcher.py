"""HMM matcher (Teixeira et al.) on hand-made tiny cases built directly in the table formats.

Each person is a piecewise-linear path through key frames (t, x, y); the helpers below turn
those into ``floor_detections`` (20 Hz, optional noise, privacy quantisation and blindness to
people standing still) and ``imu`` (100 Hz specific force with a sin^2 gait bob in the phone
frame, magnetometer = world field rotated into the phone frame; the phone's x axis points along
the walking direction, held while standing).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from scipy.ndimage import gaussian_filter1d

from trackroom.sim.simulate import SIMULATOR_ONLY
from trackroom.estimators.base import EstimatorError
from trackroom.estimators.gait import GaitModel
from trackroom.estimators.hmm_matcher import HMMMatcher
from trackroom.metrics.score import evaluate
from trackroom.scenes.loader import load_scene
from trackroom.recording import Calibration, Observations, Recording, Truth

G = 9.81
FIELD = (0.0, -0.5, 0.0)


def path(keys, t):
    """Positions (N, 2) along key frames [(t, x, y), ...] (linear, held before/after), smoothed
    by a 0.25 s Gaussian so that accelerations stay human (no velocity steps)."""
    k = np.asarray(keys, float)
    p = np.stack([np.interp(t, k[:, 0], k[:, 1]), np.interp(t, k[:, 0], k[:, 2])], axis=1)
    return gaussian_filter1d(p, 0.25 / (t[1] - t[0]), axis=0, mode="nearest")


def synthetic_recording(people: dict[str, list], phones: dict[str, str], duration: float, seed: int = 0,
                        floor_sigma: float = 0.0, privacy: bool = False, accel_sigma: float = 0.03,
                        mag_sigma: float = 0.02, bob: float = 0.03, pocket_deg: dict[str, float] | None = None) -> Recording:
    """people: person id -> key frames; phones: person id -> phone id (absent: no phone);
    pocket_deg: person id -> the phone's yaw offset in the pocket (deg, default 0)."""
    rng = np.random.default_rng(seed)
    scene = load_scene("overhead_lab", {"cameras.*.privacy": privacy})
    rate, fps = 100.0, 20.0
    t = np.arange(int(round(duration * rate))) / rate
    truth, det, imu = [], [], []
    for pid, keys in people.items():
        p = path(keys, t)
        v = np.gradient(p, t, axis=0)
        speed = np.hypot(v[:, 0], v[:, 1])
        walking = speed > 0.05
        yaw = np.arctan2(v[:, 1], v[:, 0])
        # heading held while standing (first walking heading before the first step)
        idx = np.where(walking, np.arange(len(t)), -1)
        idx = np.maximum.accumulate(idx)
        first = np.flatnonzero(walking)[0] if walking.any() else 0
        yaw = np.where(idx >= 0, yaw[np.maximum(idx, 0)], yaw[first])
        # gait bob: z = A a(s) (sin^2(pi phi) - 1/2), phi = integral of step rate
        amp = bob * np.clip(speed / 0.5, 0, 1)
        phi = np.cumsum(1.0 + 0.6 * speed) / rate
        z = amp * (np.sin(np.pi * phi) ** 2 - 0.5)
        az = np.gradient(np.gradient(z, t), t)
        a = np.gradient(v, t, axis=0)
        phone = phones.get(pid, "")
        truth.append(pd.DataFrame({"t": t, "person_id": pid, "x": p[:, 0], "y": p[:, 1], "z": 0.9 + z, "yaw": yaw,
                                   "vx": v[:, 0], "vy": v[:, 1], "walking": walking, "phone_id": phone}))
        cam_rows = np.arange(0, len(t), int(rate / fps))
        seen = cam_rows if not privacy else cam_rows[speed[cam_rows] > 0.1]
        xy = p[seen] + floor_sigma * rng.standard_normal((len(seen), 2))
        if privacy:
            xy = np.round(xy / 0.15) * 0.15
        det.append(pd.DataFrame({"t": t[seen], "camera": "ceil_sw", "x": xy[:, 0], "y": xy[:, 1]}))
        if phone:
            phone_yaw = yaw + np.radians((pocket_deg or {}).get(pid, 0.0))
            c, s = np.cos(phone_yaw), np.sin(phone_yaw)
            f = np.stack([a[:, 0], a[:, 1], az + G], axis=1)  # specific force, world frame
            fx, fy = c * f[:, 0] + s * f[:, 1], -s * f[:, 0] + c * f[:, 1]  # rotate by -yaw
            mx, my = c * FIELD[0] + s * FIELD[1], -s * FIELD[0] + c * FIELD[1]
            n = len(t)
            imu.append(pd.DataFrame({
                "t": t, "phone_id": phone,
                "ax": fx + accel_sigma * rng.standard_normal(n), "ay": fy + accel_sigma * rng.standard_normal(n),
                "az": f[:, 2] + accel_sigma * rng.standard_normal(n),
                "gx": 0.0, "gy": 0.0, "gz": 0.0,
                "mx": mx + mag_sigma * 0.5 * rng.standard_normal(n), "my": my + mag_sigma * 0.5 * rng.standard_normal(n),
                "mz": 0.0 + mag_sigma * 0.5 * rng.standard_normal(n),
            }))
    sort = lambda parts: pd.concat(parts, ignore_index=True).sort_values("t", kind="stable").reset_index(drop=True)
    cams = {c.name: c for c in scene.cameras}
    noise = {k: v for k, v in dataclasses.asdict(scene.sensors).items() if k not in SIMULATOR_ONLY}
    noise.update(floor_sigma_m=floor_sigma, magnetic_field=list(FIELD))
    return Recording(
        calibration=Calibration(cameras=cams, floorplan=scene.floorplan, noise=noise),
        observations=Observations({"floor_detections": sort(det), "imu": sort(imu)}, duration),
        truth=Truth({"people": sort(truth)}),
        meta={"scene": "synthetic", "seed": seed, "sensing": "analytic"},
    )


def run(rec: Recording, **params) -> pd.DataFrame:
    return HMMMatcher(**params).estimate(rec.observations, rec.calibration)


def per_person_accuracy(rec: Recording, tracks: pd.DataFrame, t_from: float = 0.0) -> dict[str, float]:
    """Fraction of frames (t >= t_from) in which the track nearest each person claims its phone."""
    truth = rec.truth.people
    out = {}
    for pid, g in truth.groupby("person_id"):
        hits = n = 0
        for t, row in tracks[tracks["t"] >= t_from].groupby("t"):
            tr = g.iloc[np.argmin(np.abs(g["t"].to_numpy() - t))]
            d = np.hypot(row["x"] - tr["x"], row["y"] - tr["y"]).to_numpy()
            if d.min() > 0.6:
                continue
            n += 1
            hits += row["phone_id"].iloc[int(np.argmin(d))] == tr["phone_id"]
        out[pid] = hits / max(n, 1)
    return out


# The phones of these scenarios sit straight in their pockets, and the people walk straight legs
# whose directions tell them apart: the cases below test the tracker, the carrying of evidence
# and the assignment with the paper's heading model, a phone pointing where its carrier walks
# (no pocket offset to integrate out; a constant heading difference would otherwise be no
# evidence, see test_phones_turned_in_their_pockets_are_matched_by_how_they_turn).
ALIGNED = {"pocket_sigma_deg": 0.0}

# Two people cross at right angles in the middle of the room at t = 4 s.
CROSSING = {"A": [(0, 2, 5), (1, 2, 5), (7, 8, 5), (10, 8, 5)], "B": [(0, 5, 2), (1, 5, 2), (7, 5, 8), (10, 5, 8)]}
# Fig. 4: A and B walk towards each other, meet, stand 3 s; then A walks away and B stays still.
MEETING = {"A": [(0, 2, 5), (3, 4.75, 5), (6, 4.75, 5), (9, 4.75, 8), (12, 4.75, 8)],
           "B": [(0, 8, 5), (3, 5.25, 5), (12, 5.25, 5)]}


def test_crossing_people_are_identified_after_the_crossing():
    rec = synthetic_recording(CROSSING, {"A": "phA", "B": "phB"}, 10.0, floor_sigma=0.1)
    tracks = run(rec, **ALIGNED)
    # the crossing cuts both tracks (ambiguity 3.6-4.75 s); evidence gathered before it is carried
    # over, so both are claimed right from shortly after it to the end
    acc = per_person_accuracy(rec, tracks, t_from=5.5)
    assert min(acc.values()) > 0.95, acc
    ev = evaluate(rec, tracks)
    assert ev.identification.id_accuracy > 0.98  # eq. 22: (almost) no wrong claim at any time
    assert ev.identification.identifications > 0.4 * len(tracks)  # both stand still for the first second


def test_crossing_with_swapped_phones_follows_the_phones():
    # the same paths with the phones exchanged: the claims must follow the phones, not the paths
    rec = synthetic_recording(CROSSING, {"A": "phB", "B": "phA"}, 10.0, floor_sigma=0.1)
    acc = per_person_accuracy(rec, run(rec, **ALIGNED), t_from=5.5)
    assert min(acc.values()) > 0.95, acc


@pytest.mark.parametrize("privacy", [False, True])
def test_meeting_then_one_stays_still(privacy):
    rec = synthetic_recording(MEETING, {"A": "phA", "B": "phB"}, 12.0, floor_sigma=0.05, privacy=privacy)
    tracks = run(rec, **ALIGNED)
    # after A leaves (t > 6 s) the walker must carry A's phone: the still phone says "stopped"
    if not privacy:
        late = per_person_accuracy(rec, tracks, t_from=8.0)
        assert late["A"] > 0.9 and late["B"] > 0.9, late
    else:
        # A reappears after standing unseen next to B: who it is must come from its own walk
        # (the carried evidence is at most the log-odds of the continuation, both are close),
        # so A is claimed once that walk outweighs Omega_min, before it stops at 9 s
        last = per_person_accuracy(rec, tracks, t_from=8.9)
        assert last["A"] > 0.9, last
        walker = tracks[(tracks["t"] > 6.0) & (tracks["y"] > 5.6)]
        assert set(walker["phone_id"]) <= {"", "phA"}
        # B is invisible to a privacy camera while standing: no track may claim B's phone near A
        claims = tracks[(tracks["t"] > 7.5) & (tracks["phone_id"] == "phB")]
        assert len(claims) == 0


def test_phoneless_person_gets_no_phone():
    # A and B walk distinguishable paths (opposite directions); C, without a phone, crosses them
    people = {"A": [(0, 2, 2), (6, 8, 2), (12, 8, 8)], "B": [(0, 8, 8), (6, 2, 8), (12, 2, 2)],
              "C": [(0, 5, 3), (4, 5, 7), (8, 2, 5), (12, 8, 5)]}
    rec = synthetic_recording(people, {"A": "phA", "B": "phB"}, 12.0, floor_sigma=0.1)
    tracks = run(rec, **ALIGNED)
    truth_c = rec.truth.people.query("person_id == 'C'")
    bad = 0
    for t, row in tracks.groupby("t"):
        tr = truth_c.iloc[np.argmin(np.abs(truth_c["t"].to_numpy() - t))]
        d = np.hypot(row["x"] - tr["x"], row["y"] - tr["y"]).to_numpy()
        bad += bool(d.min() < 0.5 and row["phone_id"].iloc[int(np.argmin(d))] != "")
    assert bad / len(tracks["t"].unique()) < 0.05
    acc = per_person_accuracy(rec, tracks, t_from=4.0)
    assert acc["A"] > 0.9 and acc["B"] > 0.9, acc


def test_output_columns_and_determinism():
    rec = synthetic_recording(CROSSING, {"A": "phA", "B": "phB"}, 4.0, floor_sigma=0.1)
    a, b = run(rec), run(rec)
    assert list(a.columns) == ["t", "track_id", "x", "y", "vx", "vy", "phone_id"]
    pd.testing.assert_frame_equal(a, b)
    # a phone is claimed by at most one track per frame
    claimed = a[a["phone_id"] != ""]
    assert not claimed.duplicated(["t", "phone_id"]).any()


def test_bad_input_is_named(tmp_path):
    rec = synthetic_recording(CROSSING, {"A": "phA", "B": "phB"}, 2.0)
    obs = Observations({"floor_detections": rec.observations["floor_detections"]}, 2.0)
    with pytest.raises(EstimatorError, match="IMU"):
        HMMMatcher().estimate(obs, rec.calibration)
    with pytest.raises(EstimatorError, match="evidence_weight"):
        run(rec, evidence_weight=0.0)
    bad = tmp_path / "gait.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="gait model"):
        run(rec, gait_model=str(bad))
    assert HMMMatcher.applies_to(obs, rec.calibration) is not None


def test_gait_model_separates_walking_from_standing():
    rec = synthetic_recording(MEETING, {"A": "phA", "B": "phB"}, 12.0)
    from trackroom.estimators.gait import bobbing_feature, load_default

    imu = rec.observations["imu"].query("phone_id == 'phB'")
    tq = np.array([1.5, 9.0])  # B walking at 1.5 s, standing at 9 s
    g = bobbing_feature(imu["t"].to_numpy(), imu[["ax", "ay", "az"]].to_numpy(), tq, 0.8)
    assert list(load_default().walking(g)) == [True, False]
    assert isinstance(load_default(), GaitModel)


def test_output_track_ids_follow_the_phone_and_the_filtered_track():
    from trackroom.estimators.hmm_matcher import output_track_ids

    # frames 0-3, filtered tracks 0 and 1; track 0 claims phone 0 in frames 1-2 only, then in
    # frame 3 track 1 claims phone 0 (track 0 must give the label up)
    frame = np.array([0, 0, 1, 1, 2, 2, 3, 3])
    track = np.array([0, 1, 0, 1, 0, 1, 0, 1])
    assigned = np.array([-1, -1, 0, -1, 0, -1, -1, 0])
    ids = output_track_ids(frame, track, assigned, ["phX"])
    assert list(ids) == ["anon0", "anon1", "phX", "anon1", "phX", "anon1", "anon0", "phX"]
    ids = output_track_ids(frame[:6], track[:6], np.array([-1, -1, 0, -1, -1, -1]), ["phX"])
    assert list(ids[4:]) == ["phX", "anon1"]  # unclaimed, keeps its last phone's label


def _two_standing_tracks(p_swap: float, mate_vanishes: bool):
    """Segments by hand: tracks 0 and 1 (segments 0, 1) in frames 0-19, both cut at frame 20
    (segments 2, 3, each the other's swap partner, ``p_swap``), then both stand still to frame 39
    (segment 3 vanishes after frame 29 if ``mate_vanishes``). Segment 0 carries 30 nats for
    phone 0, segment 1 -10; after the cut nothing tells them apart (own evidence 0). Continuity
    links each new segment to its own old segment only (the two stood 0.6 m apart)."""
    from trackroom.estimators.lazy_tracker import Segments

    rows = []
    for k in range(40):
        rows.append((k, 0 if k < 20 else 2, 0))
        if k < 20 or not mate_vanishes or k < 30:
            rows.append((k, 1 if k < 20 else 3, 1))
    r = pd.DataFrame(rows, columns=["frame", "segment", "track"])
    last = r.groupby("segment")["frame"].max()
    info = pd.DataFrame({"start_frame": [0, 0, 20, 20], "end_frame": last.reindex(range(4)).to_numpy(),
                         "end_reason": ["proximity", "proximity", "end", "missed" if mate_vanishes else "end"]})
    w = 1.77
    preds = {2: [(0, w)], 3: [(1, w)]}
    segs = Segments(rows=r, info=info, predecessors=preds, frame_times=np.arange(40) / 20.0,
                    continues={2: (0, p_swap), 3: (1, p_swap)}, partner={2: 1, 3: 0})
    own = np.zeros((len(r), 1))
    own[r["segment"].to_numpy() == 0, 0] = np.linspace(0, 30, 20)
    own[r["segment"].to_numpy() == 1, 0] = np.linspace(0, -10, 20)
    return segs, own


@pytest.mark.parametrize("vanishes", [False, True])
def test_claim_is_held_after_a_possible_swap_while_both_stand(monkeypatch, vanishes):
    # seed 1 of the phoneless study: a phone carrier and a phoneless person stand close, the
    # tracker may have swapped them (p_swap = 0.2), continuity does not link the two (they are
    # 0.6 m apart), and standing still gives no evidence either way: no claim until they move
    from trackroom.estimators.hmm_matcher import PhoneFeatures

    segs, own = _two_standing_tracks(0.2, mate_vanishes=vanishes)
    phones = PhoneFeatures(["phone0"], np.zeros((40, 1)), np.zeros((40, 1)))
    monkeypatch.setattr(HMMMatcher, "segment_llr", lambda self, s, p, g, prior=None: own)
    seg = segs.rows["segment"].to_numpy()
    gait = GaitModel.__new__(GaitModel)
    held = HMMMatcher().assign(segs, phones, gait)
    assert (held[seg == 0] == 0).any()  # before the cut the phone is claimed
    assert (held[seg >= 2] == -1).all()  # after it, not (lead log(0.8 / 0.2) = 1.4 < margin_min)
    if vanishes:
        # without the frozen rival, the mate vanishing (a privacy camera misses it standing)
        # would hand the phone to the track that is left
        plain = HMMMatcher(hold_rival=False).assign(segs, phones, gait)
        assert (plain[(seg == 2) & (segs.rows["frame"].to_numpy() >= 30)] == 0).all()
    old = HMMMatcher(swap_partner=False).assign(segs, phones, gait)
    assert (old[seg == 2] == 0).all()  # the former rule: the mate's share is lost, the claim made
    # a small p_swap does not hold the claim back
    segs, own = _two_standing_tracks(0.005, mate_vanishes=vanishes)
    monkeypatch.setattr(HMMMatcher, "segment_llr", lambda self, s, p, g, prior=None: own)
    sure = HMMMatcher().assign(segs, phones, gait)
    assert (sure[segs.rows["segment"].to_numpy() == 2] == 0).all()


def legs(start, t0, segments, speed=0.9):
    """Key frames: standing at ``start`` until t0, then straight legs [(direction deg, duration s), ...]."""
    x, y = start
    t, keys = t0, [(0.0, x, y), (t0, x, y)]
    for ang, dur in segments:
        x += np.cos(np.radians(ang)) * dur * speed
        y += np.sin(np.radians(ang)) * dur * speed
        t += dur
        keys.append((t, x, y))
    return keys


def test_phones_turned_in_their_pockets_are_matched_by_how_they_turn():
    # A zig-zags east/north; B walks 40 deg further left, turning at other times. A's phone sits
    # turned +40 deg in the pocket, B's -35 deg: A's phone points along B's first leg. Read as
    # headings with no offset (pocket_sigma_deg=0, the paper's model), neither phone fits either
    # track and nothing is claimed; with the offset integrated out, the phones are matched by
    # turning when their tracks turn.
    people = {"A": legs((1.0, 1.0), 1.0, [(0, 3), (90, 3), (0, 3), (90, 3)]),
              "B": legs((3.0, 1.0), 1.0, [(40, 4.5), (130, 3), (40, 3), (130, 1.5)])}
    rec = synthetic_recording(people, {"A": "phA", "B": "phB"}, 13.0, floor_sigma=0.1,
                              pocket_deg={"A": 40.0, "B": -35.0})
    tracks = run(rec)
    acc = per_person_accuracy(rec, tracks, t_from=7.0)
    assert min(acc.values()) > 0.95, acc
    ev = evaluate(rec, tracks)
    assert ev.identification.id_accuracy == 1.0
    fixed = run(rec, pocket_sigma_deg=0.0)
    assert (fixed["phone_id"] != "").mean() < 0.5 * (tracks["phone_id"] != "").mean()


def test_heading_evidence_integrates_the_pocket_offset_out():
    from scipy import integrate, stats

    from trackroom.estimators.hmm_matcher import heading_evidence

    rng = np.random.default_rng(3)
    w, kappa0 = 0.5, 2.0
    delta = rng.uniform(-np.pi, np.pi, (5, 2))
    kappa = rng.uniform(0.5, 20.0, (5, 2))
    seg = np.array([7, 3, 7, 3, 7])  # two segments, interleaved in frame order
    ev = heading_evidence(delta, kappa, seg, w, kappa0)
    for s in (3, 7):
        rows = seg == s
        for j in range(2):
            d, k = delta[rows, j], kappa[rows, j]
            # log of the integral over the offset o of prior(o) prod_k [2 pi vm(d_k; o, kappa_k)]^w
            f = lambda o: stats.vonmises.pdf(o, kappa0) * np.prod(
                (2 * np.pi * stats.vonmises.pdf(d, k, loc=o)) ** w)
            expected = np.log(integrate.quad(f, -np.pi, np.pi, limit=200)[0])
            assert ev[rows, j].sum() == pytest.approx(expected, abs=1e-7)
    # a flat prior: a constant heading difference is no evidence (any offset explains it)
    flat = heading_evidence(delta + 1.3, kappa, seg, w, 0.0)
    assert flat.sum() == pytest.approx(heading_evidence(delta, kappa, seg, w, 0.0).sum(), abs=1e-9)
    # a prior far more concentrated than the data: the fixed-offset von Mises ratio
    sharp = heading_evidence(delta, kappa, seg, w, 1e8)
    fixed = w * (stats.vonmises.logpdf(delta, kappa) + np.log(2 * np.pi))
    np.testing.assert_allclose(sharp, fixed, atol=1e-5)
    np.testing.assert_allclose(heading_evidence(delta, kappa, seg, w, np.inf), fixed, atol=1e-12)
