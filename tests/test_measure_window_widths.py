"""scripts/measure_window_widths.py: the models' image widths (``tp_geometry.cylinder_image_width``)
and the summary of window widths."""
import numpy as np
import pandas as pd
import pytest

from scripts.measure_window_widths import summary
from trackroom.estimators.tp_geometry import cylinder_image_width as image_width
from tests.test_target_planes import right_angle_pair


def test_a_cylinder_nearer_the_camera_is_wider_and_its_rounded_ends_narrow_it():
    south, _ = right_angle_pair()
    near, far = image_width(south.P, [3.0, -1.0], 0.0, 1.8, 0.2), image_width(south.P, [3.0, 1.0], 0.0, 1.8, 0.2)
    assert near > far > 0.0
    # the body's part (rims at 0.2 and 1.6 m) is narrower near a camera above it than the full cylinder
    assert image_width(south.P, [3.0, -1.0], 0.2, 1.6, 0.2) < near


def test_summary_gives_each_models_median_and_robust_sigma_by_width():
    D = pd.DataFrame({"camera": "c", "window": [30.0, 31.0, 32.0, 70.0],
                      "cylinder": [29.0, 29.0, 29.0, 80.0], "body": [30.0, 30.0, 30.0, 70.0]})
    S = summary(D).set_index(["model", "model width px"])
    assert S.loc[("cylinder", "all"), "windows"] == 4
    assert S.loc[("cylinder", "25-40"), "median px"] == pytest.approx(2.0)
    assert S.loc[("cylinder", "60-1000"), "median px"] == pytest.approx(-10.0)
    assert S.loc[("body", "25-40"), "median px"] == pytest.approx(1.0)
    assert S.loc[("body", "25-40"), "robust sigma px"] == pytest.approx(1.4826 * 1.0, abs=0.01)
    assert ("body", "0-25") not in S.index  # no window in that bin
