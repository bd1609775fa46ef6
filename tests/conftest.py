"""Test-wide settings, applied before numpy or mujoco are imported.

Hypothesis profiles, shared by every property-based suite (tests/test_props_*.py): ``ci`` (the
default) keeps each suite to a few hundred cases in all; ``slow`` runs >= 1000 cases per test.
Choose with the environment variable TRACKROOM_HYPOTHESIS=ci|slow; per-test case counts go
through ``examples(n_ci)`` so that they scale with the profile.
"""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering on the CPU
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see scripts/cli.py

from hypothesis import HealthCheck, settings  # noqa: E402

HYPOTHESIS_PROFILE = os.environ.get("TRACKROOM_HYPOTHESIS", "ci")
# derandomize in CI: the same cases every run, so a red build is reproducible; slow explores anew
settings.register_profile("ci", max_examples=100, deadline=None, derandomize=True, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("slow", max_examples=1000, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
if HYPOTHESIS_PROFILE not in ("ci", "slow"):
    raise ValueError(f"TRACKROOM_HYPOTHESIS must be ci or slow, got {HYPOTHESIS_PROFILE!r}")
settings.load_profile(HYPOTHESIS_PROFILE)


def examples(n_ci: int) -> int:
    """Hypothesis cases for one test: ``n_ci`` in the ci profile, at least 1000 in slow."""
    return max(1000, n_ci) if HYPOTHESIS_PROFILE == "slow" else n_ci
