"""scripts/measure_merged_edges.py: which windows' edges are measured, and against whom."""
import numpy as np
import pandas as pd
import pytest

from scripts.measure_merged_edges import edge_errors, lag_pairs, summarise

W = 320.0


def test_a_merged_window_is_measured_against_its_outermost_members():
    people = np.array([[100.0, 120.0], [115.0, 140.0]])
    out = edge_errors(people, np.array([True, True]), np.array([[98.0, 143.0]]), W)
    assert out == [(2, "left", -2.0, 20.0), (2, "right", 3.0, 25.0)]


def test_a_window_of_one_person_alone():
    people = np.array([[100.0, 120.0], [200.0, 230.0]])
    out = edge_errors(people, np.array([True, True]), np.array([[101.0, 119.5], [199.0, 231.0]]), W)
    assert out == [(1, "left", 1.0, 20.0), (1, "right", -0.5, 20.0), (1, "left", -1.0, 30.0), (1, "right", 1.0, 30.0)]


@pytest.mark.parametrize("people, visible, window", [
    ([[100.0, 120.0], [118.0, 150.0]], [True, True], [100.0, 121.0]),  # touches a person less than half inside
    ([[100.0, 120.0]], [False], [100.0, 120.0]),  # its person partly hidden by the floor plan
    ([[0.0, 20.0]], [True], [0.0, 20.0]),  # on the image border
    ([[-10.0, 20.0]], [True], [1.0, 20.0]),  # its person cut by the border
    ([[100.0, 120.0]], [True], [200.0, 220.0]),  # nobody in it
    ([[np.nan, np.nan]], [True], [100.0, 120.0]),  # a person behind the camera is nobody
])
def test_windows_not_measured(people, visible, window):
    assert edge_errors(np.array(people), np.array(visible), np.array([window]), W) == []


def test_summary_per_window_kind():
    rng = np.random.default_rng(0)
    edges = pd.DataFrame({"members": [1] * 4000 + [2] * 4000, "err_px": rng.normal(0, 1, 8000),
                          "z": np.r_[rng.normal(0, 1, 4000), rng.normal(0, 2, 4000)]})
    s = summarise(edges).set_index("members")
    assert list(s.index) == ["one", "two or more"]
    assert s.loc["one", "edges"] == 4000
    assert abs(s.loc["one", "z_robust_sigma"] - 1.0) < 0.05 and abs(s.loc["two or more", "z_robust_sigma"] - 2.0) < 0.1


def test_the_same_edge_in_the_next_frame_is_paired_and_its_persistence_measured():
    """An edge is paired with the same camera track's same side in the frame after, of the same
    kind (one member, or more); errors that persist (an AR(1) of coefficient 0.8) give a rank
    correlation near 0.8 and a frame-to-frame change of sd sqrt(2 (1 - 0.8)), independent ones
    near 0 and sqrt(2)."""
    rng = np.random.default_rng(1)
    n = 4000
    ar = np.empty(n)
    ar[0] = rng.normal()
    for k in range(1, n):
        ar[k] = 0.8 * ar[k - 1] + np.sqrt(1 - 0.8**2) * rng.normal()
    t = np.round(0.1 * np.arange(1, n + 1), 1)
    common = {"recording": "r", "camera": "obl_ne", "side": "left", "t": np.r_[t, t], "frame": np.r_[np.arange(1, n + 1), np.arange(1, n + 1)]}
    edges = pd.DataFrame({**common, "track": [0] * n + [1] * n, "members": [2] * n + [1] * n,
                          "z": np.r_[ar, rng.normal(size=n)], "err_px": 0.0})
    # a right edge in the same frames is another edge, and a frame missing breaks the pair
    edges = pd.concat([edges, edges.iloc[:3].assign(side="right")], ignore_index=True).drop(index=[10])
    pairs = lag_pairs(edges)
    assert len(pairs) == 2 * (n - 1) - 2 + 2
    s = summarise(edges).set_index("members")
    assert abs(s.loc["two or more", "next_frame_r"] - 0.8) < 0.05 and abs(s.loc["one", "next_frame_r"]) < 0.05
    assert abs(s.loc["two or more", "change_sd"] - np.sqrt(0.4)) < 0.05 and abs(s.loc["one", "change_sd"] - np.sqrt(2)) < 0.1
