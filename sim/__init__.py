"""Simulation: the MuJoCo world, walkers, sensing, recordings and dataset I/O.

Importing ``trackroom.sim`` does not import MuJoCo. The recording contract lives in
``trackroom.recording`` and ``trackroom.dataset`` (no simulator needed).
"""
