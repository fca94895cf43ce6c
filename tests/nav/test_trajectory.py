"""Trajectory representation: evaluation, continuity, exact effort, trapezoidal profiles."""

import numpy as np
import pytest
from scipy.integrate import quad

from legplan.nav import Trajectory, trapezoidal_polyline


def test_effort_matches_numerical_integration_and_pieces_join():
    rng = np.random.default_rng(2)
    pieces, p, v = [], np.zeros(2), np.array([0.3, -0.1])
    for _ in range(4):
        a0, jerk, T = rng.normal(size=2), rng.normal(size=2), rng.uniform(0.2, 1.0)
        pieces.append((p, v, a0, jerk, T))
        p = p + v * T + a0 * T**2 / 2 + jerk * T**3 / 6
        v = v + a0 * T + jerk * T**2 / 2
    trajectory = Trajectory.from_pieces(pieces)
    knots = trajectory.knots
    numeric = sum(quad(lambda t: float((trajectory.evaluate(t)[2] ** 2).sum()), t0 + 1e-12,
                       t1 - 1e-12)[0] for t0, t1 in zip(knots[:-1], knots[1:]))
    assert trajectory.effort() == pytest.approx(numeric, rel=1e-8)
    end_p, end_v = trajectory.end_state()
    np.testing.assert_allclose(end_p, p), np.testing.assert_allclose(end_v, v)
    before = trajectory.evaluate(trajectory.knots[1:-1] - 1e-9)
    after = trajectory.evaluate(trajectory.knots[1:-1] + 1e-9)
    np.testing.assert_allclose(before[0], after[0], atol=1e-7)
    np.testing.assert_allclose(before[1], after[1], atol=1e-7)
    assert Trajectory(trajectory.segments).duration == trajectory.duration


@pytest.mark.parametrize("points", [[[0, 0], [3, 0], [3, 4]], [[0, 0], [0.1, 0.05]],
                                    [[1, 1], [4, 4], [4, 4], [0, 5]]])
def test_trapezoid_respects_per_axis_limits_and_is_time_optimal_per_segment(points):
    v_max, a_max = 0.75, 1.0
    trajectory = trapezoidal_polyline(np.array(points, float), v_max, a_max)
    _, p, v, a = trajectory.sample(1e-3)
    assert np.abs(v).max() <= v_max + 1e-9 and np.abs(a).max() <= a_max + 1e-9
    np.testing.assert_allclose(p[-1], points[-1], atol=1e-9)
    # the straight segment (0,0)→(3,0) of 3 m: accelerate 0.75 s, cruise 3.25 s, decelerate 0.75 s
    if points[1] == [3, 0]:
        assert trajectory.segments[:3, 8] == pytest.approx([0.75, 3.25, 0.75])


def test_path_length_of_a_polyline_is_the_sum_of_its_segments():
    # a polyline stops at every vertex, so the integrated speed runs along each straight segment once
    trajectory = trapezoidal_polyline(np.array([[0, 0], [3, 0], [3, 4], [0, 0]], float), 0.75, 1.0)
    assert trajectory.path_length() == pytest.approx(3 + 4 + 5, rel=1e-6)
