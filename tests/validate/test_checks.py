import numpy as np
import pytest

from legplan.validate import Validator


def _lifted(robot, dz):
    q = robot.q_nominal.copy()
    q[2] += dz
    return q


def test_flat_ground_clearance_is_lowest_sphere_height_minus_radius(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    Q = np.stack([_lifted(scarab, dz) for dz in (0.0, 0.05, 0.2)])
    stance = np.ones((3, scarab.n_legs), bool)
    checks = validator.check(Q, stance)
    # expectation from the robot layer's sphere centres (a different FK code path) on z = 0 ground
    centres = scarab.sphere_centres(Q)
    checked = ~np.asarray(scarab.spheres.is_foot)
    expected = (centres[:, checked, 2] - scarab.spheres.radii[checked]).min(axis=1)
    np.testing.assert_allclose(checks.clearance, expected, atol=1e-9)
    np.testing.assert_allclose(checks.foot_gap, np.array([0.0, 0.05, 0.2])[:, None]
                               + scarab.foot_positions(scarab.q_nominal)[0, :, 2], atol=1e-9)


def test_fcl_distance_of_a_body_sphere_equals_height_minus_radius(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    q = _lifted(scarab, 0.1)
    _, centres, _ = validator.kinematics(q[None])
    body = np.flatnonzero(np.asarray(scarab.spheres.leg_index) == -1)[0]
    d = validator.surface.fcl_distance(centres[0, body:body + 1])[0] - scarab.spheres.radii[body]
    assert d == pytest.approx(q[2] - scarab.spheres.radii[body], abs=1e-9)


def test_swing_foot_sphere_counts_and_stance_foot_sphere_does_not(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    q = scarab.q_nominal.copy()
    stance = np.ones(scarab.n_legs, bool)
    all_stance = validator.check(q[None], stance[None])
    stance[1] = False
    one_swing = validator.check(q[None], stance[None])
    foot_radius = scarab.spheres.radii[np.asarray(scarab.spheres.is_foot)][0]
    assert all_stance.clearance[0] > 0
    # the swing foot tip is on the ground, so its sphere penetrates by its radius (up to 3 um of
    # the nominal stance's foot height)
    assert one_swing.clearance[0] == pytest.approx(-foot_radius, abs=1e-5)
    assert np.isnan(one_swing.foot_gap[0, 1])


def test_com_margin_against_independent_polygon_and_sign(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    q = scarab.q_nominal.copy()
    stance = np.ones((2, scarab.n_legs), bool)
    stance[1, [0, 1, 2]] = False  # only the right legs: the CoM is outside their triangle
    checks = validator.check(np.stack([q, q]), stance)
    feet = scarab.foot_positions(q)[0, :, :2]
    order = [0, 1, 2, 5, 4, 3]  # lf lm lr rr rm rf: the hexagon around the body
    com = checks.com[0, :2]
    dists = []
    for a, b in zip(feet[order], np.roll(feet[order], -1, axis=0)):
        e = b - a
        dists.append(abs(e[0] * (com[1] - a[1]) - e[1] * (com[0] - a[0])) / np.linalg.norm(e))
    assert checks.com_margin[0] == pytest.approx(min(dists), abs=1e-9)
    assert checks.com_margin[1] < -0.2


def test_com_margin_of_many_configurations_equals_each_ones_own_polygon(scarab, flat_terrain):
    """The margins of a batch (grouped by stance and footholds) are those of every configuration's
    own support polygon: mixed stance layouts, footholds shared by some configurations, moved for
    others, and a stance of one foot (no polygon: -inf)."""
    from legplan.geometry.polygon import support_polygon

    validator = Validator(scarab, flat_terrain)
    rng = np.random.default_rng(3)
    n, legs = 40, scarab.n_legs
    Q = np.repeat(scarab.q_nominal[None], n, axis=0)
    Q[:, :2] += rng.uniform(-0.05, 0.05, (n, 2))
    stance = np.ones((n, legs), bool)
    stance[10:20, 1] = False
    stance[20:30, [0, 3]] = False
    stance[30, :] = False
    stance[30, 2] = True  # one stance foot
    footholds = np.repeat(scarab.foot_positions(scarab.q_nominal)[0][None], n, axis=0)
    footholds[25:29, 4, :2] += 0.03  # the same layout, another foothold for a few
    checks = validator.check(Q, stance, footholds)
    for i in range(n):
        if stance[i].sum() < 2:
            assert checks.com_margin[i] == -np.inf
            continue
        own = support_polygon(footholds[i, stance[i], :2]).signed_distance(checks.com[i:i + 1, :2])[0]
        assert checks.com_margin[i] == pytest.approx(own, abs=1e-12)


def test_joint_excess_and_valid(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    q = scarab.q_nominal.copy()
    q[7] = scarab.upper[0] + 0.1
    checks = validator.check(np.stack([scarab.q_nominal, q]), np.ones((2, scarab.n_legs), bool))
    assert checks.joint_excess[0].max() == 0
    assert checks.joint_excess[1, 0] == pytest.approx(0.1)
    assert checks.valid().tolist() == [True, False]


def test_pruned_clearance_equals_brute_force_fcl(scarab, step_terrain):
    validator = Validator(scarab, step_terrain)
    rng = np.random.default_rng(1)
    n = 40
    Q = np.repeat(scarab.q_nominal[None], n, axis=0)
    Q[:, 0] = rng.uniform(0.1, 0.45, n)  # body over the block edge at x = 0.3
    Q[:, 2] += rng.uniform(-0.03, 0.08, n)
    Q[:, 7:] += rng.uniform(-0.3, 0.3, (n, scarab.n_joints))
    stance = rng.random((n, scarab.n_legs)) < 0.7
    checks = validator.check(Q, stance)
    _, centres, _ = validator.kinematics(Q)
    brute = validator.surface.fcl_distance(centres.reshape(-1, 3)).reshape(n, -1) - scarab.spheres.radii
    exempt = stance[:, scarab.spheres.leg_index] & np.asarray(scarab.spheres.is_foot)
    exempt[:, np.asarray(scarab.spheres.leg_index) < 0] = False
    brute[exempt] = np.inf
    np.testing.assert_allclose(checks.clearance, brute.min(axis=1), atol=1e-9)
