"""Every TEB residual term's analytic Jacobian against central finite differences, and the merged
objective's JᵀJ, Jᵀh against the stacked Jacobian."""

import numpy as np
import pytest

from legplan.geometry.angles import wrap_angle
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.objective import TebObjective, weighted
from legplan.nav.teb.residuals import (AccelerationTerm, ClearanceTerm, NonholonomicTerm, PathTerm, TimeTerm,
                                       VelocityTerm, ViaPointTerm, YawChangeTerm)
from legplan.solve import check_jacobian, check_normal_terms
from legplan.terrain.grid import Grid2D


def random_band(n=7, seed=0):
    rng = np.random.default_rng(seed)
    poses = np.column_stack([np.linspace(0, 3, n) + 0.1 * rng.standard_normal(n),
                             0.3 * rng.standard_normal(n), rng.uniform(-3, 3, n)])
    dt = rng.uniform(0.2, 0.5, n - 1)
    return poses.ravel(), dt


def z(poses, dt=None):
    """Band vector z(poses, dt) (dt of a uniform 0.3 s band when not given)."""
    dt = np.full(len(poses) // 3 - 1, 0.3) if dt is None else dt
    return [np.concatenate([poses, dt])]


def synthetic_field():
    grid = Grid2D((-1.0, -2.0), 0.1, (41, 61))
    X, Y = grid.centres()
    distance = np.hypot(X - 1.5, Y - 1.2) + 0.3 * np.sin(X)
    return DistanceField(distance, grid)


def assert_ok(block, values):
    report = check_jacobian(block, values)
    assert report.ok(atol=1e-6, rtol=1e-5), report


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_velocity_and_time_blocks(seed):
    poses, dt = random_band(seed=seed)
    assert_ok(VelocityTerm(7), z(poses, dt))
    assert_ok(TimeTerm(7), z(poses, dt))


@pytest.mark.parametrize("boundary", [(None, None), ([0.3, 0.05, -0.1], None), (None, [0, 0, 0]),
                                      ([0.2, 0, 0.1], [0.1, -0.05, 0])])
def test_acceleration_block(boundary):
    poses, dt = random_band(seed=3)
    block = AccelerationTerm(7, *boundary)
    assert block.size == 15 + 3 * sum(b is not None for b in boundary)
    assert_ok(block, z(poses, dt))


def test_acceleration_of_two_pose_band_has_only_boundary_rows():
    poses, dt = random_band(n=2, seed=4)
    block = AccelerationTerm(2, [0.1, 0, 0], [0, 0, 0])
    assert block.size == 6
    assert_ok(block, z(poses, dt))


def test_path_block_interior_and_vertex():
    path = np.array([[0, 0], [1.0, 0.0], [1.0, 1.5], [2.5, 1.5]])
    poses = np.array([[0.4, 0.3, 0], [1.3, 0.7, 0], [1.5, 1.9, 0], [3.0, 1.2, 0]]).ravel()
    block = PathTerm(4, path, first=np.array([0, 0, 1, 1]), width=2)
    assert_ok(block, z(poses))
    r = block.evaluate(z(poses), False)[0].reshape(-1, 2)
    assert np.allclose(r[0], [0, 0.3]) and np.allclose(r[1], [0.3, 0]) and np.allclose(r[3], [0.5, -0.3])


def test_clearance_block_matches_finite_differences():
    poses, _ = random_band(seed=5)
    assert_ok(ClearanceTerm(7, synthetic_field()), z(poses))


def test_distance_field_interpolates_exactly_at_cell_centres_and_clamps_outside():
    field = synthetic_field()
    grid = field.grid
    X, Y = grid.centres()
    pts = np.column_stack([X.ravel()[::97], Y.ravel()[::97]])
    assert np.allclose(field.values(pts), field.distance.ravel()[::97])
    value, gradient = field.value_and_gradient(np.array([[-5.0, 0.0]]))
    assert value[0] == pytest.approx(grid.bilinear(field.distance, [[-1.0, 0.0]])[0])
    assert gradient[0, 0] == 0.0


def test_via_point_block_with_and_without_heading():
    poses, _ = random_band(seed=6)
    block = ViaPointTerm(7, [2, 4], [[1.0, 0.2], [2.0, -0.1]], [np.nan, 3.0])
    assert block.size == 5
    assert_ok(block, z(poses))


def test_yaw_change_and_nonholonomic_blocks():
    poses, _ = random_band(seed=7)
    assert_ok(YawChangeTerm(7), z(poses))
    assert_ok(NonholonomicTerm(7), z(poses))


def test_yaw_change_wraps_across_pi():
    poses = np.array([[0, 0, np.pi - 0.05], [0.1, 0, -np.pi + 0.05]]).ravel()
    r = YawChangeTerm(2).evaluate(z(poses), False)[0]
    assert r[0] == pytest.approx(0.1)
    assert wrap_angle(np.pi) == pytest.approx(np.pi) and wrap_angle(-np.pi) == pytest.approx(np.pi)


def test_nonholonomic_residual_vanishes_on_a_circular_arc():
    phi = np.linspace(0, 1.2, 6)
    poses = np.column_stack([np.sin(phi), 1 - np.cos(phi), phi]).ravel()  # unit circle, heading tangent
    r = NonholonomicTerm(6).evaluate(z(poses), False)[0]
    assert np.max(np.abs(r)) < 1e-12


def test_objective_normal_terms_match_stacked_jacobian():
    poses, dt = random_band(seed=8)
    path = np.array([[0, 0], [1.5, 0.2], [3.0, -0.1]])
    entries = [weighted(VelocityTerm(7), 2.0, -0.2, 0.5, 0.01), weighted(AccelerationTerm(7, [0.1, 0, 0]), 1.5, -0.3, 0.3),
               weighted(TimeTerm(7), 1.0), weighted(PathTerm(7, path, np.zeros(7, int), 2), 0.7),
               weighted(ClearanceTerm(7, synthetic_field()), 3.0, 0.8, np.inf, 0.01),
               weighted(NonholonomicTerm(7), 4.0)]
    objective = TebObjective(7, entries)
    values = z(poses, dt)
    assert check_normal_terms(objective, values) < 1e-9
    assert_ok(objective, values)
    h = objective.evaluate(values, False)[0]
    assert np.count_nonzero(h[:18]) > 0 and np.count_nonzero(h[:18]) < 18  # some velocity limits active, not all
