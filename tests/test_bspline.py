"""trackroom.sim.bspline: the walkers' splines equal scipy.interpolate's to rounding."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline, make_lsq_spline

from trackroom.sim.bspline import interp_spline, lsq_spline, not_a_knot


def _uniform_knots(x, spacing, k):
    n_int = max(0, int(np.floor((x[-1] - x[0]) / spacing)) - 1)
    inner = np.linspace(x[0], x[-1], n_int + 2)[1:-1]
    return np.concatenate([[x[0]] * (k + 1), inner, [x[-1]] * (k + 1)])


@pytest.mark.parametrize("k", [3, 5])
def test_lsq_spline_equals_scipy_norm_eq(k):
    rng = np.random.default_rng(4)
    x = np.arange(3000) * 0.01
    y = np.cumsum(rng.normal(size=(3000, 2, 3)), axis=0) * 0.01  # components of any shape
    knots = _uniform_knots(x, 0.2, k)
    ours = lsq_spline(x, y, knots, k)
    ref = make_lsq_spline(x, y, knots, k=k, method="norm-eq")
    xs = np.linspace(-0.5, x[-1] + 0.5, 777)  # and beyond the ends (extrapolation)
    for nu in range(4):
        want = ref(xs, nu)
        assert ours(xs, nu).shape == want.shape
        np.testing.assert_allclose(ours(xs, nu), want, rtol=0, atol=1e-9 * np.abs(want).max())


def test_lsq_spline_reproduces_a_polynomial_exactly():
    x = np.linspace(0.0, 4.0, 400)
    y = 1.0 - 2.0 * x + 0.5 * x**3 - 0.1 * x**5
    s = lsq_spline(x, y, _uniform_knots(x, 0.5, 5), 5)
    np.testing.assert_allclose(s(x), y, atol=1e-9)
    np.testing.assert_allclose(s(x, 1), -2.0 + 1.5 * x**2 - 0.5 * x**4, atol=1e-8)
    np.testing.assert_allclose(s(x, 2), 3.0 * x - 2.0 * x**3, atol=1e-7)
    np.testing.assert_array_equal(s(x, 6), 0.0)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6, 7, 8, 50])
def test_interp_spline_equals_scipy_for_every_degree_the_walkers_use(n):
    # the walkers' short-path fallback: k = min(5, n - 1 - (n even)), 0 for one sample
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(0.0, 1.0, n))
    y = rng.normal(size=(n, 3))
    k = min(5, n - 1 - (n % 2 == 0)) if n > 1 else 0
    ours = interp_spline(x, y, k)
    ref = make_interp_spline(x, y, k=k)
    np.testing.assert_array_equal(ours.t, ref.t)
    np.testing.assert_allclose(ours(x), y, atol=1e-9)  # it interpolates
    xs = np.linspace(-0.1, 1.1, 60)
    for nu in range(3):
        want = ref(xs, nu)
        np.testing.assert_allclose(ours(xs, nu), want, rtol=0, atol=1e-8 * max(1.0, np.abs(want).max()))


def test_interp_spline_long_uniform_series_matches_scipy():
    x = np.arange(20000) * 0.01
    y = np.sin(x[:, None] * np.array([1.0, 3.0, 7.0])) * 0.03
    ours, ref = interp_spline(x, y, 5), make_interp_spline(x, y, k=5)
    for nu in range(3):
        np.testing.assert_allclose(ours(x, nu), ref(x, nu), rtol=0, atol=1e-9)


def test_not_a_knot_knots_equal_scipys():
    from scipy.interpolate._bsplines import _not_a_knot

    x = np.sort(np.random.default_rng(0).uniform(size=11))
    for k in (2, 3, 4, 5):
        np.testing.assert_array_equal(not_a_knot(x, k), _not_a_knot(x, k))


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="strictly increasing"):
        interp_spline([0.0, 1.0, 1.0, 2.0], np.zeros(4), 3)
    with pytest.raises(ValueError, match="samples"):
        lsq_spline(np.arange(10.0), np.zeros(9), _uniform_knots(np.arange(10.0), 2.0, 3), 3)


def test_the_simulation_does_not_import_scipy_interpolate():
    # the reason this module exists: scipy.interpolate's imports cost every generate 0.1-0.3 s
    code = "import sys, trackroom.sim.simulate, trackroom.dataset; print('scipy.interpolate' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
