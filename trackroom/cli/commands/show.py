"""trackroom show: a top-down PNG of a recording (or a scene), and optional frame contact sheets."""
from __future__ import annotations

from pathlib import Path

NAME = "show"
HELP = "draw a recording folder (or a scene) top-down as a PNG: walls, cameras and views, true paths, detections"


def add_arguments(p) -> None:
    p.add_argument("target", help="a recording folder, or a scene name / TOML file")
    p.add_argument("--out", help="PNG path (default: DIR/topdown.png for a recording, SCENE.png for a scene)")
    p.add_argument("--frames", action="store_true", help="also write a contact sheet PNG per camera (recordings with saved frames)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")


def run(args) -> int:
    from trackroom.errors import CommandError
    from trackroom.topdown import plot_recording, plot_scene

    target = Path(args.target)
    if (target / "manifest.json").exists():
        from trackroom.dataset import read_recording

        rec = read_recording(target)
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
    if args.frames:
        raise CommandError("--frames needs a recording folder")
    from trackroom.scenes import load_scene

    scene = load_scene(args.target, args.overrides)
    out = Path(args.out) if args.out else Path(f"{scene.name}.png")
    plot_scene(scene, out)
    print(f"wrote {out}")
    return 0
