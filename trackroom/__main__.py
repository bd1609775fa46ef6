"""``python -m trackroom``: the same as the ``trackroom`` command."""
import sys

from trackroom.cli import main

sys.exit(main())
