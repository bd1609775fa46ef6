"""scripts/measure_window_rows.py: windows wholly above the heads or below the feet of the people in
their columns, on synthetic windows."""
from __future__ import annotations

import numpy as np

from scripts.measure_window_rows import frame_off_rows, summary


def test_a_window_off_the_rows_of_everyone_in_its_columns_is_counted_with_its_gap():
    people = np.array([[100.0, 120.0, 80.0, 200.0],   # near: head at row 80
                       [110.0, 125.0, 60.0, 150.0],   # farther, overlapping it: head at row 60
                       [200.0, 220.0, 70.0, 160.0],
                       [np.nan] * 4])                  # behind the camera
    windows = np.array([[101.0, 119.0, 82.0, 198.0],   # on the near person
                        [101.0, 105.0, 65.0, 70.0],    # above the near one's head, not over the farther one's columns
                        [112.0, 118.0, 50.0, 55.0],    # above both heads (the farther one's at 60)
                        [202.0, 218.0, 165.0, 170.0],  # below the third one's feet
                        [300.0, 310.0, 10.0, 20.0]])   # over nobody
    none, above, below = frame_off_rows(people, windows)
    assert none == 1
    assert above == [10.0, 5.0]
    assert below == [5.0]
    line = summary(5, none, above, below)
    assert "wholly above every overlapping person's head: 2 (40.000 %)" in line and "max 10.0 px" in line
    assert "wholly below every one's feet: 1" in line


def test_a_window_over_a_persons_rows_is_not_counted():
    none, above, below = frame_off_rows(np.array([[0.0, 10.0, 50.0, 150.0]]), np.array([[2.0, 8.0, 40.0, 52.0]]))
    assert (none, above, below) == (0, [], [])
