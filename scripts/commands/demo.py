"""trackroom demo: the main job on the bundled scenes, end to end."""
from __future__ import annotations

from pathlib import Path

NAME = "demo"
HELP = "generate overhead_lab and bearing_hall recordings into a folder and draw them"


def add_arguments(p) -> None:
    p.add_argument("--out", help="folder for the demo's recordings and pictures (default: a new temp folder)")
    p.add_argument("--duration", type=float, default=20.0, help="simulated seconds per scene (default 20)")
    p.add_argument("--seed", type=int, default=0)


def run(args) -> int:
    import tempfile

    from scenes import load_scene
    from scripts.commands.generate import generate_to, summary_line
    from scripts.topdown import plot_recording

    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="trackroom-demo-"))
    root.mkdir(parents=True, exist_ok=True)
    for name in ("overhead_lab", "bearing_hall"):
        rec, seconds, folder = generate_to(load_scene(name), args.seed, args.duration, "analytic", root / name, force=True)
        print(summary_line(rec, seconds, folder))
        png = plot_recording(rec, folder / "topdown.png")
        print(f"  picture: {png}")
    print(f"demo output in {root}")
    return 0
