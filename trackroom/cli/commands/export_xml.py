"""``trackroom export-xml SCENE``: write a scene's MuJoCo world as MJCF (open it in MuJoCo's viewer)."""
from __future__ import annotations

import sys
from pathlib import Path

NAME = "export-xml"
HELP = "write a scene's MuJoCo model as MJCF XML (for MuJoCo's viewer)"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="bundled scene name or path to a scene TOML file")
    parser.add_argument("--out", type=Path, default=None, help="output file (default: standard output)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE", help="override a scene field, e.g. walkers.count=10 (repeatable)")


def run(args) -> int:
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.world import build_world

    scene = load_scene(args.scene, args.overrides)
    xml = build_world(scene).to_xml()
    if args.out is None:
        sys.stdout.write(xml)
    else:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(xml)
        print(f"wrote {args.out} ({len(scene.walkers)} walkers, {len(scene.cameras)} cameras)", file=sys.stderr)
    return 0
