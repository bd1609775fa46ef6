"""The ``trackroom`` command line (``main``); each sub-command is a module in ``commands/``."""
from .main import build_parser, main

__all__ = ["build_parser", "main"]
