"""metrics.aggregate.robust_sigma: 1.4826 MAD, the measurement scripts' one robust sigma. It gives
a normal sample's standard deviation, ignores a minority of outliers, leaves NaN out as pandas'
median does, and equals the pandas and numpy expressions the scripts wrote inline before."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.props import examples
from trackroom.metrics.aggregate import robust_sigma


def test_a_normal_samples_sd_and_outliers_ignored():
    x = np.random.default_rng(0).normal(3.0, 2.0, 20000)
    assert abs(robust_sigma(x) - 2.0) < 0.05
    y = np.r_[x, np.full(2000, 1e6)]  # a tenth more, all far out
    assert abs(robust_sigma(y) - 2.0) < 0.3
    assert robust_sigma([1.0, 1.0, 1.0]) == 0.0


def test_nan_left_out_and_none_left_is_nan():
    assert robust_sigma([1.0, np.nan, 3.0, 5.0]) == robust_sigma([1.0, 3.0, 5.0]) == 1.4826 * 2.0
    assert math.isnan(robust_sigma([])) and math.isnan(robust_sigma([np.nan]))


@settings(max_examples=examples(200))
@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=40))
def test_equals_the_inline_expressions_it_replaced(xs):
    s = pd.Series(xs)
    x = np.asarray(xs)
    assert robust_sigma(s) == float(1.4826 * (s - s.median()).abs().median())
    assert robust_sigma(x) == 1.4826 * float(np.median(np.abs(x - float(np.median(x)))))
