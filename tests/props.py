"""Case counts for the hypothesis suites, by the profile tests/conftest.py loads."""
import os


def examples(n_ci: int) -> int:
    """Cases for one property: ``n_ci`` under the ``ci`` profile, at least 1000 under ``slow``."""
    return max(1000, n_ci) if os.environ.get("TRACKROOM_HYPOTHESIS", "ci") == "slow" else n_ci
