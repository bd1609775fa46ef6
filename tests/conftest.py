"""Test-wide settings, applied before numpy or mujoco are imported."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering on the CPU
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # see scripts/cli.py
