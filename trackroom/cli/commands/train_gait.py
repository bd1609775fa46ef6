"""trackroom train-gait: fit the HMM matcher's phone models from training recordings.

As in Teixeira et al. (Fig. 6), the walking / stopped classes of the vertical-bobbing feature are
fitted from labelled training data: a Gaussian for walking and an exponential for stopped. The
labels come from the training recordings' ground truth (each phone's carrier and whether that
person was walking). The same pass fits the magnetometer heading noise against the true walking
direction (von Mises concentration, about each phone's own mean offset: how the phone sits in the
pocket is not noise) and the walking-speed distribution. See ``estimators/gait.py``.
"""
from __future__ import annotations

NAME = "train-gait"
HELP = "fit the hmm_matcher gait/heading model from training recordings (uses their ground truth)"


def add_arguments(p) -> None:
    p.add_argument("recordings", nargs="+", metavar="DIR", help="training recording folders")
    p.add_argument("--out", required=True, help="output JSON file (e.g. gait.json)")
    p.add_argument("--window", type=float, default=0.8, help="bobbing window, s (default 0.8)")
    p.add_argument("--rate", type=float, default=20.0, help="feature sample rate, Hz (default 20)")


def training_samples(rec, window_s: float, rate: float):
    """(features, walking labels, heading errors while walking, speeds while walking) of one recording."""
    import numpy as np

    from trackroom.estimators.gait import bobbing_feature, phone_heading
    from trackroom.recording import RecordingError

    imu = rec.observations["imu"]
    people = rec.truth.people
    if not len(imu):
        raise RecordingError(f"recording {rec.scene!r} seed {rec.seed}: no IMU samples to train on")
    field = rec.calibration.noise.get("magnetic_field", (0.0, -0.5, 0.0))
    feats, labels, herr, speeds = [], [], [], []
    for phone, d in imu.groupby("phone_id", sort=True):
        carrier = people[people["phone_id"].astype(str) == str(phone)]
        if not len(carrier):
            continue
        t = d["t"].to_numpy(float)
        tq = np.arange(np.ceil((t[0] + window_s) * rate), np.floor(t[-1] * rate) + 1) / rate
        acc = d[["ax", "ay", "az"]].to_numpy(float)
        g = bobbing_feature(t, acc, tq, window_s)
        psi = phone_heading(t, acc, d[["mx", "my", "mz"]].to_numpy(float), tq, 1.0 / rate, field)
        ct = carrier["t"].to_numpy(float)
        j = np.clip(np.searchsorted(ct, tq), 0, len(ct) - 1)
        # a window is labelled walking when the carrier walked for all of it, stopped when for none
        walk = carrier["walking"].to_numpy(bool)
        cw = np.concatenate([[0], np.cumsum(walk)])
        j0 = np.clip(np.searchsorted(ct, tq - window_s), 0, len(ct) - 1)
        frac = (cw[j + 1] - cw[j0]) / np.maximum(j + 1 - j0, 1)
        sure = (frac == 1.0) | (frac == 0.0)
        feats.append(g[sure]); labels.append(frac[sure] == 1.0)
        vx, vy = carrier["vx"].to_numpy(float)[j], carrier["vy"].to_numpy(float)[j]
        speed = np.hypot(vx, vy)
        moving = (frac == 1.0) & (speed > 0.3)
        err = psi[moving] - np.arctan2(vy, vx)[moving]
        # the phone's constant yaw offset in the pocket (its circular mean) is not noise: the
        # matcher integrates it out itself (hmm_matcher.heading_evidence)
        herr.append(err - np.angle(np.exp(1j * err).mean()) if len(err) else err)
        speeds.append(speed[moving])
    if not feats:
        raise RecordingError(f"recording {rec.scene!r} seed {rec.seed}: no phone is carried by anyone in the truth")
    return tuple(np.concatenate(a) for a in (feats, labels, herr, speeds))


def run(args) -> int:
    import numpy as np

    from trackroom.estimators.gait import fit_gait
    from trackroom.errors import CommandError
    from trackroom.dataset import read_recording

    if args.window <= 0 or args.rate <= 0:
        raise CommandError("--window and --rate must be positive")
    recs = [read_recording(d) for d in args.recordings]
    parts = [training_samples(r, args.window, args.rate) for r in recs]
    what = ", ".join(f"{r.scene} seed {r.seed} ({r.duration:g} s, {r.sensing})" for r in recs)
    g, w, h, s = (np.concatenate([p[i] for p in parts]) for i in range(4))
    try:
        model = fit_gait(g, w, h, s, args.window, source=f"trackroom train-gait on {what}")
    except ValueError as e:
        raise CommandError(str(e)) from None
    model.to_json(args.out)
    print(f"{args.out}: walking g ~ N({model.walk_mu:.3f}, {model.walk_sigma:.3f}^2) m/s^2 "
          f"({model.stats['walking_samples']} windows), stopped g ~ Exp(scale {model.stop_scale:.4f}) "
          f"({model.stats['stopped_samples']}), heading kappa {model.heading_kappa:.1f}, "
          f"speed {model.speed_mu:.2f} +- {model.speed_sigma:.2f} m/s")
    return 0
