"""trackroom show: a top-down PNG of a recording (or a scene), optional frame contact sheets, and
an estimator's tracks over the truth (``--tracks``: colour per track, truth in grey, identity
switches marked where the CLEAR MOT matching finds them)."""
from __future__ import annotations

from pathlib import Path

NAME = "show"
HELP = "draw a recording folder (or a scene) top-down as a PNG: walls, cameras and views, true paths, detections"


def add_arguments(p) -> None:
    p.add_argument("target", help="a recording folder, or a scene name / TOML file")
    p.add_argument("--out", help="PNG path (default: DIR/topdown.png for a recording, SCENE.png for a scene)")
    p.add_argument("--frames", action="store_true", help="also write a contact sheet PNG per camera (recordings with saved frames)")
    p.add_argument("--tracks", metavar="CSV",
                   help="draw this tracks CSV over the recording's truth instead (default --out: CSV with .png)")
    p.add_argument("--gate", type=float, default=1.0, help="with --tracks: match gate for finding identity switches, m (default 1)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")


def run(args) -> int:
    from trackroom.errors import CommandError
    from trackroom.topdown import plot_recording, plot_scene

    target = Path(args.target)
    if (target / "manifest.json").exists():
        from trackroom.dataset import read_recording

        rec = read_recording(target)
        if args.tracks:
            return _show_tracks(rec, args)
        out = Path(args.out) if args.out else target / "topdown.png"
        plot_recording(rec, out)
        print(f"wrote {out}")
        if args.frames:
            if not (target / "frames").is_dir():
                raise CommandError(f"{target}: no saved frames (generate with --sensing rendered --save-frames)")
            from trackroom.sim.contact_sheet import contact_sheets

            for png in contact_sheets(target, out.parent):
                print(f"wrote {png}")
        return 0
    if target.is_dir():
        raise CommandError(f"{target}: not a trackroom recording (no manifest.json)")
    if args.frames or args.tracks:
        raise CommandError(f"{'--frames' if args.frames else '--tracks'} needs a recording folder")
    from trackroom.scenes import load_scene

    scene = load_scene(args.target, args.overrides)
    out = Path(args.out) if args.out else Path(f"{scene.name}.png")
    plot_scene(scene, out)
    print(f"wrote {out}")
    return 0


def _show_tracks(rec, args) -> int:
    from trackroom.dataset import read_tracks
    from trackroom.errors import CommandError
    from trackroom.topdown import plot_tracks

    if not args.gate > 0:
        raise CommandError(f"--gate must be a positive distance in metres, got {args.gate}")
    if args.frames:
        raise CommandError("give --frames or --tracks, not both")
    tracks = read_tracks(args.tracks)
    if not len(tracks):
        raise CommandError(f"{args.tracks}: no track rows to draw")
    out = Path(args.out) if args.out else Path(args.tracks).with_suffix(".png")
    plot_tracks(rec, tracks, out, args.gate, name=Path(args.tracks).stem)
    print(f"wrote {out}")
    return 0
