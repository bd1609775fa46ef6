"""Test-wide settings, applied before numpy or mujoco are imported."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering on the CPU
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see trackroom/cli/main.py

# Hypothesis case counts: "ci" (default) keeps each property suite to a few hundred cases;
# TRACKROOM_HYPOTHESIS=slow runs >= 1000 per property (see tests/props.py).
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile(
    "ci", deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
settings.register_profile(
    "slow", deadline=None, max_examples=1000,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
settings.load_profile(os.environ.get("TRACKROOM_HYPOTHESIS", "ci"))
