"""trackroom score: score a tracks CSV against a recording's ground truth."""
from __future__ import annotations

NAME = "score"
HELP = "score tracks.csv against a recording's truth (CLEAR MOT, HOTA, IDF1, position error, ID accuracy)"

TABLE = [
    ("MOTA", "mota", "{:.3f}"), ("MOTP (m)", "motp", "{:.3f}"), ("ID switches", "id_switches", "{:d}"),
    ("false positives", "fp", "{:d}"), ("misses", "fn", "{:d}"), ("IDF1", "idf1", "{:.3f}"),
    ("HOTA", "hota", "{:.3f}"), ("  DetA / AssA", ("deta", "assa"), "{:.3f} / {:.3f}"),
    ("  LocA (similarity)", "loca", "{:.3f}"),
    ("recall", "recall", "{:.3f}"), ("precision", "precision", "{:.3f}"),
    ("position RMSE (m)", "rmse", "{:.3f}"), ("  median / p90 (m)", ("p50", "p90"), "{:.3f} / {:.3f}"),
    ("  seen by 0 cameras", "rmse_cam0", "{:.3f}"), ("  seen by 1 camera", "rmse_cam1", "{:.3f}"),
    ("  seen by >= 2", "rmse_cam2plus", "{:.3f}"),
    ("ID accuracy (claims)", "id_accuracy", "{:.3f}"), ("ID accuracy (all people)", "id_accuracy_all", "{:.3f}"),
]


def add_arguments(p) -> None:
    p.add_argument("recording", metavar="DIR", help="recording folder with truth")
    p.add_argument("tracks", help="tracks CSV (t, track_id, x, y [, phone_id])")
    p.add_argument("--gate", type=float, default=1.0, help="match distance gate in metres (default 1); HOTA's similarity is max(0, 1 - d / gate)")
    p.add_argument("--person", metavar="ID", default=None,
                   help="score against this person's truth alone (a single-target tracker; ids as in truth/people)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")


def load_tracks(path):
    """A tracks CSV, validated (``trackroom.dataset.read_tracks``)."""
    from trackroom.dataset import read_tracks

    return read_tracks(path)


def _nan(v) -> bool:
    return isinstance(v, float) and v != v


def run(args) -> int:
    import json
    import math

    from trackroom.metrics.identity import claims_phones
    from trackroom.metrics.score import evaluate
    from trackroom.errors import CommandError
    from trackroom.dataset import read_recording

    if not args.gate > 0:
        raise CommandError(f"--gate must be a positive distance in metres, got {args.gate}")
    rec = read_recording(args.recording)
    tracks = load_tracks(args.tracks)
    person = None
    if args.person is not None:
        from trackroom.metrics.score import find_person

        try:
            person = find_person(rec, args.person)
        except ValueError as e:
            raise CommandError(f"--person: {e}") from None
    m = evaluate(rec, tracks, args.gate, person=person).metrics()
    if args.json:
        clean = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in m.items()}
        if not claims_phones(tracks):
            del clean["id_accuracy"], clean["id_accuracy_all"]
        who = {"person": str(person)} if person is not None else {}
        print(json.dumps({"scene": rec.scene, "seed": rec.seed, "sensing": rec.sensing, **who, **clean}))
        return 0
    who = f"person {person}" if person is not None else f"{m['people']} people"
    print(f"{rec.scene} seed {rec.seed} ({rec.sensing}), {m['frames']} frames, {who}, "
          f"{m['tracks']} tracks, gate {args.gate:g} m")
    for label, key, fmt in TABLE:
        keys = key if isinstance(key, tuple) else (key,)
        vals = [m[k] for k in keys]
        if any(_nan(v) for v in vals):
            if keys[0].startswith("id_accuracy"):
                continue  # no phone claims: not applicable
            cell = "-"
        else:
            cell = fmt.format(*[int(v) if "d}" in fmt else v for v in vals])
        print(f"  {label:<26}{cell}")
    return 0
