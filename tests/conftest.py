"""Test-wide settings, applied before numpy or mujoco are imported.

Hypothesis profiles, shared by every property-based suite (tests/test_props_*.py): ``ci`` (the
default) keeps each suite to a few hundred cases in all; ``slow`` runs >= 1000 cases per test.
Choose with the environment variable TRACKROOM_HYPOTHESIS=ci|slow; per-test case counts go
through ``examples(n_ci)`` so that they scale with the profile.
"""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering on the CPU
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see trackroom/cli/main.py

# Hypothesis case counts: "ci" (default) keeps each property suite to a few hundred cases, the
# same cases every run (derandomize), so a red build is reproducible; TRACKROOM_HYPOTHESIS=slow
# runs >= 1000 per property (tests/props.py: examples) and explores anew.
from hypothesis import HealthCheck, settings  # noqa: E402

from tests.props import HYPOTHESIS_PROFILE, examples  # noqa: E402,F401  (examples: re-exported)

_QUIET = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
settings.register_profile("ci", max_examples=100, deadline=None, derandomize=True, print_blob=True,
                          suppress_health_check=_QUIET)
settings.register_profile("slow", max_examples=1000, deadline=None, print_blob=True, suppress_health_check=_QUIET)
settings.load_profile(HYPOTHESIS_PROFILE)


import pytest  # noqa: E402


@pytest.fixture(scope="session")
def occlusion_lab_6s(tmp_path_factory) -> str:
    """Folder of an analytic occlusion_lab recording, seed 3, 6 s, written once for the session
    (scripts' tests that read a recording from disk)."""
    from trackroom.dataset import write_recording
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    out = tmp_path_factory.mktemp("occlusion_lab_6s") / "rec"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 6.0, "analytic"), out)
    return str(out)
