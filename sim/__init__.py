"""Simulation: the MuJoCo world, walkers, sensing, recordings and dataset I/O.

Importing ``sim`` does not import MuJoCo; ``sim.recording`` (the contract) is safe for estimators.
"""
