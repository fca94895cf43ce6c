"""Vector parametrization x = [p, ω, joints] (eq. (1b)): so3 maps vs pinocchio, round trip, tangent map."""

import numpy as np
import pinocchio as pin
import pytest

from legplan.robots.so3 import (quat_to_rotvec, right_jacobian, rotvec_to_matrix, rotvec_to_quat)

from robot_helpers import random_configurations


def _rotvecs(rng, n=40):
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, n - 6), [0.0, 1e-9, 1e-5, 1e-3, np.pi - 1e-6, np.pi]])
    return axis * angles[:, None]


def test_so3_maps_match_pinocchio():
    omega = _rotvecs(np.random.default_rng(0))
    R = rotvec_to_matrix(omega)
    Jr = right_jacobian(omega)
    for k, w in enumerate(omega):
        np.testing.assert_allclose(R[k], pin.exp3(w), rtol=0, atol=1e-14)
        np.testing.assert_allclose(Jr[k], pin.Jexp3(w), atol=1e-9)
        quat = pin.Quaternion(pin.exp3(w)).coeffs()          # (x, y, z, w)
        np.testing.assert_allclose(rotvec_to_quat(w[None])[0] * np.sign(quat[3] or 1.0), quat, atol=1e-9)
        if np.linalg.norm(w) < np.pi - 1e-3:
            np.testing.assert_allclose(quat_to_rotvec(quat[None])[0], pin.log3(pin.exp3(w)), atol=1e-9)


def test_quaternion_sign_and_angle_range():
    omega = _rotvecs(np.random.default_rng(1))
    quat = rotvec_to_quat(omega)
    back = quat_to_rotvec(-quat)                              # -q is the same rotation
    np.testing.assert_allclose(rotvec_to_matrix(back), rotvec_to_matrix(omega), atol=1e-9)
    assert np.all(np.linalg.norm(back, axis=1) <= np.pi + 1e-12)


def test_round_trip_vector_configuration(any_robot):
    rng = np.random.default_rng(2)
    Q = random_configurations(any_robot, rng, 30)
    X = any_robot.to_vector(Q)
    assert X.shape == (30, any_robot.nv)
    Q2 = any_robot.from_vector(X)
    # Same configuration (quaternion up to sign): zero pinocchio difference.
    diff = np.array([pin.difference(any_robot.model, a, b) for a, b in zip(Q, Q2)])
    np.testing.assert_allclose(diff, 0.0, atol=1e-10)
    np.testing.assert_allclose(any_robot.to_vector(Q2), X, atol=1e-10)


def test_tangent_map_by_finite_differences(any_robot):
    """pin.difference(q(x), q(x + h e_k)) / h ≈ tangent_map(x)[:, k] (central differences)."""
    robot = any_robot
    rng = np.random.default_rng(3)
    X = robot.to_vector(random_configurations(robot, rng, 5))
    T = robot.tangent_map(X)
    h = 1e-6
    for i, x in enumerate(X):
        q0 = robot.from_vector(x)[0]
        fd = np.empty((robot.nv, robot.nx))
        for k in range(robot.nx):
            step = np.zeros(robot.nx)
            step[k] = h
            qp, qm = robot.from_vector(x + step)[0], robot.from_vector(x - step)[0]
            fd[:, k] = (pin.difference(robot.model, q0, qp) - pin.difference(robot.model, q0, qm)) / (2 * h)
        np.testing.assert_allclose(T[i], fd, atol=1e-7)


def test_shape_errors(scarab2):
    with pytest.raises(ValueError, match=r"\(n, 25\)"):
        scarab2.foot_positions(np.zeros((2, 24)))
    with pytest.raises(ValueError, match=r"\(n, 24\)"):
        scarab2.from_vector(np.zeros(25))


def test_read_only_inputs_are_accepted():
    """OMPL's callbacks hand read-only state views; scipy's Rotation refuses those buffers."""
    omega = np.array([[0.1, -0.2, 0.3]])
    omega.flags.writeable = False
    quat = rotvec_to_quat(omega)
    quat.flags.writeable = False
    assert np.allclose(quat_to_rotvec(quat), omega) and np.allclose(rotvec_to_matrix(omega)[0], pin.exp3(omega[0]))
