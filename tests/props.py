"""Case counts for the hypothesis suites: the profile tests/conftest.py loads, from the
environment variable TRACKROOM_HYPOTHESIS ("ci", the default, or "slow")."""
import os

HYPOTHESIS_PROFILE = os.environ.get("TRACKROOM_HYPOTHESIS", "ci")
if HYPOTHESIS_PROFILE not in ("ci", "slow"):
    raise ValueError(f"TRACKROOM_HYPOTHESIS must be ci or slow, got {HYPOTHESIS_PROFILE!r}")


def examples(n_ci: int) -> int:
    """Cases for one property: ``n_ci`` under the ``ci`` profile, at least 1000 under ``slow``."""
    return max(1000, n_ci) if HYPOTHESIS_PROFILE == "slow" else n_ci
