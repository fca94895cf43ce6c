"""Bernstein basis, derivatives and degree elevation (eq. (6), (7), (15)) against direct formulas."""

from math import comb

import numpy as np
import pytest

from legplan.geometry import bezier


def _de_casteljau(P, t):
    pts = np.array(P, float)
    while len(pts) > 1:
        pts = (1 - t) * pts[:-1] + t * pts[1:]
    return pts[0]


@pytest.fixture
def control_points():
    return np.random.default_rng(3).normal(size=(6, 4))  # degree 5 in R^4


def test_bernstein_partition_of_unity_and_endpoints():
    t = np.linspace(0, 1, 17)
    for d in range(0, 11):
        B = bezier.bernstein_matrix(d, t)
        assert np.allclose(B.sum(axis=1), 1.0)
        assert np.all(B >= 0)
        assert np.allclose(B[0], np.eye(d + 1)[0]) and np.allclose(B[-1], np.eye(d + 1)[-1])
    assert np.isclose(bezier.bernstein_matrix(4, [0.3])[0, 2], comb(4, 2) * 0.3**2 * 0.7**2)


def test_evaluate_matches_de_casteljau(control_points):
    t = np.linspace(0, 1, 9)
    expected = np.array([_de_casteljau(control_points, ti) for ti in t])
    assert np.allclose(bezier.evaluate(control_points, t), expected)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_derivatives_match_finite_differences(control_points, order):
    t = np.linspace(0.05, 0.95, 7)
    h = 1e-3
    lower = bezier.evaluate(control_points, t, order - 1)
    fd = (bezier.evaluate(control_points, t + h, order - 1) - bezier.evaluate(control_points, t - h, order - 1)) / (2 * h)
    assert lower.shape == fd.shape
    assert np.allclose(bezier.evaluate(control_points, t, order), fd, atol=1e-4 * (1 + np.abs(fd).max()))


def test_derivative_beyond_degree_is_zero(control_points):
    d = len(control_points) - 1
    assert np.allclose(bezier.evaluate(control_points, [0.2, 0.7], d + 1), 0.0)  # eq. (15)
    # the d-th derivative is constant: d! Δ^d p_0
    top = bezier.evaluate(control_points, [0.1, 0.9], d)
    assert np.allclose(top[0], top[1])


def test_endpoint_derivative_is_hodograph(control_points):
    d = len(control_points) - 1
    assert np.allclose(bezier.evaluate(control_points, [0.0], 1)[0], d * (control_points[1] - control_points[0]))


def test_elevation_preserves_curve_eq7(control_points):
    t = np.linspace(0, 1, 23)
    elevated = bezier.elevate(control_points, times=4)
    assert elevated.shape == (len(control_points) + 4, control_points.shape[1])
    assert np.allclose(bezier.evaluate(elevated, t), bezier.evaluate(control_points, t))
    assert np.allclose(elevated[0], control_points[0]) and np.allclose(elevated[-1], control_points[-1])
    # eq. (7c) explicitly for one elevation
    once = bezier.elevate(control_points)
    d = len(control_points) - 1
    i = 2
    assert np.allclose(once[i], i / (d + 1) * control_points[i - 1] + (1 - i / (d + 1)) * control_points[i])


def test_linear_curve_elevates_to_uniform_points():
    P = np.array([[0.0, 0.0], [3.0, 6.0]])
    assert np.allclose(bezier.elevate(P, 2), [[0, 0], [1, 2], [2, 4], [3, 6]])


def test_derivative_norm_integrals_of_a_line_and_parabola():
    line = np.array([[0.0, 0.0], [3.0, 4.0]])
    lengths = bezier.derivative_norm_integrals(line, orders=(1, 2))
    assert np.allclose(lengths, [5.0, 0.0])
    parabola = np.array([[0.0], [0.0], [1.0]])  # x(t) = t², x' = 2t, x'' = 2
    assert np.allclose(bezier.derivative_norm_integrals(parabola, orders=(1, 2, 3)), [1.0, 2.0, 0.0])


def test_rejects_bad_arguments():
    with pytest.raises(ValueError):
        bezier.bernstein_matrix(-1, [0.5])
    with pytest.raises(ValueError):
        bezier.uniform_parameters(1)
