"""Constrained RRT-Connect on an analytic two-legged toy: both feet fixed, the body must pass an obstacle."""

import numpy as np
import pytest

from legplan.baselines.constrained import StanceConstraint, plan_constrained
from toy2 import TwoLegToy

FEET = np.array([[0.0, 0.15, 0.0], [0.0, -0.15, 0.0]])
BALL, RADIUS = np.array([0.0, 0.0, 0.3]), 0.05


@pytest.fixture(scope="module")
def toy():
    robot = TwoLegToy()
    x0 = robot.configuration([-0.1, 0.0, 0.3], FEET)
    x1 = robot.configuration([0.1, 0.0, 0.3], FEET)
    return robot, x0, x1


def valid(robot):
    """Body centre out of the ball (the straight line runs through it) and joints inside their limits."""
    def check(x):
        joints = x[6:]
        return bool(np.linalg.norm(x[:3] - BALL) > RADIUS and np.all(joints >= robot.lower)
                    and np.all(joints <= robot.upper))
    return check


def bounds(robot):
    return (np.r_[-0.3, -0.3, 0.1, -0.3, -0.3, -0.3, robot.lower],
            np.r_[0.3, 0.3, 0.5, 0.3, 0.3, 0.3, robot.upper])


def test_jacobian_matches_finite_differences(toy):
    robot, x0, _ = toy
    constraint = StanceConstraint(robot, [True, True], FEET, 1e-6)
    x = x0 + np.random.default_rng(0).normal(scale=0.05, size=12)
    jac = np.zeros((6, 12))
    constraint.jacobian(x, jac)
    fd = np.zeros((6, 12))
    for k in range(12):
        plus, minus = np.zeros(6), np.zeros(6)
        step = np.zeros(12)
        step[k] = 1e-6
        constraint.function(x + step, plus)
        constraint.function(x - step, minus)
        fd[:, k] = (plus - minus) / 2e-6
    assert np.allclose(jac, fd, atol=1e-7)


@pytest.mark.parametrize("space", ["projected", "atlas", "tangent"])
def test_path_stays_on_the_manifold_and_around_the_ball(toy, space):
    robot, x0, x1 = toy
    constraint = StanceConstraint(robot, [True, True], FEET, 1e-5)
    low, high = bounds(robot)
    result = plan_constrained(constraint, valid(robot), x0, x1, low, high, space=space, time_budget=5.0,
                              seed=3, delta=0.02)
    assert result.success, result.reason
    W = result.waypoints
    assert np.allclose(W[0], x0, atol=1e-4) and np.allclose(W[-1], x1, atol=1e-4)
    feet = robot.foot_positions(W)  # independent of the constraint's own evaluation
    assert np.abs(feet - FEET).max() <= 1e-4
    assert all(valid(robot)(w) for w in W)
    # the straight line is blocked, so the body leaves it by more than the ball's radius
    lateral = np.linalg.norm(W[:, 1:3] - BALL[1:], axis=1)
    assert lateral.max() > RADIUS


def test_blocked_goal_is_a_failure_with_a_reason(toy):
    robot, x0, _ = toy
    x_blocked = robot.configuration(BALL, FEET)
    constraint = StanceConstraint(robot, [True, True], FEET, 1e-5)
    low, high = bounds(robot)
    result = plan_constrained(constraint, valid(robot), x0, x_blocked, low, high, space="atlas",
                              time_budget=0.5, seed=0)
    assert not result.success and result.waypoints is None
    assert "RRT-Connect" in result.reason and result.status


def test_same_seed_same_path(toy):
    robot, x0, x1 = toy
    low, high = bounds(robot)
    paths = [plan_constrained(StanceConstraint(robot, [True, True], FEET, 1e-5), valid(robot), x0, x1, low, high,
                              space="atlas", time_budget=5.0, seed=7).waypoints for _ in range(2)]
    assert paths[0].shape == paths[1].shape and np.allclose(paths[0], paths[1])
