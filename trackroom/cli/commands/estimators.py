"""trackroom estimators: every estimator (bundled and plug-ins), what it needs, and its parameters.

Each parameter is listed with its type, default and the one-line doc from its Config field's
metadata (``param(default, doc)``); ``trackroom estimate --list`` prints the same.
"""
from __future__ import annotations

from trackroom.cli.commands import add_plugin_argument

NAME = "estimators"
HELP = "list every estimator (bundled and plug-ins): what it needs and every parameter with type, default and meaning"


def add_arguments(p) -> None:
    p.add_argument("names", nargs="*", metavar="NAME", help="only these estimators (default: all)")
    add_plugin_argument(p)


def needs_text(cls) -> str:
    """``imu and (floor_detections or bearings)``: the observation kinds an estimator needs."""
    parts = list(cls.requires)
    if cls.requires_any:
        anyof = " or ".join(cls.requires_any)
        parts.append(f"({anyof})" if parts and len(cls.requires_any) > 1 else anyof)
    return " and ".join(parts) + " observations" if parts else "nothing"


def describe(name: str) -> str:
    """One estimator's block: name, source, description, needs, parameters."""
    import dataclasses

    from trackroom.estimators import get, source
    from trackroom.estimators.base import config_types, type_text, value_text

    cls = get(name)
    lines = [f"{name}  ({source(name)})"]
    if cls.description:
        lines.append(f"  {cls.description}")
    lines.append(f"  needs: {needs_text(cls)}")
    fields = dataclasses.fields(cls.Config)
    if not fields:
        lines.append("  parameters: none")
        return "\n".join(lines)
    types_ = config_types(cls.Config)
    rows = []
    for f in fields:
        if f.default is not dataclasses.MISSING:
            default = value_text(f.default)
        elif f.default_factory is not dataclasses.MISSING:
            default = value_text(f.default_factory())
        else:
            default = "(required)"
        rows.append((f.name, type_text(types_[f.name]), default, str(f.metadata.get("doc", "")).strip() or "(no doc)"))
    w = [max(len(r[i]) for r in rows) for i in range(3)]
    lines.append("  parameters (--param KEY=VALUE):")
    lines += [f"    {n:<{w[0]}}  {t:<{w[1]}}  {d:<{w[2]}}  {doc}" for n, t, d, doc in rows]
    return "\n".join(lines)


def listing(names: list[str] | None = None) -> str:
    """The listing ``trackroom estimators`` prints: every estimator's block, or those named."""
    from trackroom.estimators import available, source

    est = available()
    names = list(names or est)
    plugins = sum(source(n) != "bundled" for n in est)
    head = (f"{len(est)} estimator(s): {len(est) - plugins} bundled, {plugins} from plug-ins. Set parameters with "
            "--param KEY=VALUE (estimate) or NAME[KEY=VALUE;...] (compare); values are parsed by type "
            "(true/false, integers, numbers, text, [lists], none where the type allows it).")
    return "\n\n".join([head] + [describe(n) for n in names])


def run(args) -> int:
    print(listing(args.names))
    return 0
