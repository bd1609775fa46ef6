"""The sub-commands, one module each (``NAME``, ``HELP``, ``add_arguments``, ``run``), and the
options several of them share."""


def add_plugin_argument(p) -> None:
    """``--plugin MODULE`` (repeatable): estimators of one's own; ``cli.main`` imports them before
    the command runs."""
    p.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                   help="import estimators from a module (dotted name) or a .py file before running (repeatable); "
                        "installed plug-ins (entry-point group trackroom.estimators) need no option")
