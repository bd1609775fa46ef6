"""The command line the pooled measurement scripts share: one table of rows from every recording
given, summarised once."""
from __future__ import annotations

import sys
from typing import Callable

import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import recording_folders


def run_pooled(argv: list[str], prog: str, per_recording: Callable[[str], pd.DataFrame],
               summarise: Callable[[pd.DataFrame], pd.DataFrame], nothing: str, count: bool = False) -> int:
    """``python -m scripts.PROG DIR [DIR ...]``: ``per_recording`` of every folder (globs
    expanded, every manifest read first), pooled, printed through ``summarise``; ``nothing`` is
    the message when no row comes out (exit 1); ``count`` prints the number of recordings first.
    Exit 2 without a folder."""
    if not argv:
        print(f"usage: python -m scripts.{prog} DIR [DIR ...]", file=sys.stderr)
        return 2
    folders = recording_folders(argv, prog)
    rows = pd.concat([per_recording(f) for f in folders], ignore_index=True)
    if rows.empty:
        print(nothing, file=sys.stderr)
        return 1
    if count:
        print(f"{len(folders)} recordings")
    print(summarise(rows).to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    return 0
