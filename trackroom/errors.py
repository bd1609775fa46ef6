"""Errors the command line reports as one clear line (exit status 2)."""


class CommandError(Exception):
    """A command cannot do what was asked; the message is shown as is."""
