"""Metrics: CLEAR MOT, identity, position error, the Cramér-Rao bound, tables (numpy/scipy/pandas)."""
