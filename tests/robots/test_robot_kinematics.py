"""Batch kinematics vs pinocchio's own frame placements / CoM, FCL distances and finite differences."""

import fcl
import numpy as np
import pinocchio as pin
import pytest
from robot_helpers import random_configurations

from legplan.robots.kinematics import one_dof_axis


def _oMf_points(robot, q):
    """Feet, sphere centres and CoM from pin.forwardKinematics + updateFramePlacements + oMf."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    feet = np.array([data.oMf[leg.foot_frame_id].translation for leg in robot.legs])
    spheres = np.array([data.oMf[int(f)].act(o) for f, o in zip(robot.spheres.frame_ids,
                                                                 robot.spheres.offsets)])
    return feet, spheres, pin.centerOfMass(robot.model, data, q)


def test_positions_match_pinocchio_frames(any_robot):
    robot = any_robot
    Q = random_configurations(robot, np.random.default_rng(10), 20)
    feet, spheres, com = robot.foot_positions(Q), robot.sphere_centres(Q), robot.com(Q)
    assert feet.shape == (20, robot.n_legs, 3) and spheres.shape == (20, len(robot.spheres), 3)
    for i, q in enumerate(Q):
        ref_feet, ref_spheres, ref_com = _oMf_points(robot, q)
        np.testing.assert_allclose(feet[i], ref_feet, atol=1e-12)
        np.testing.assert_allclose(spheres[i], ref_spheres, atol=1e-12)
        np.testing.assert_allclose(com[i], ref_com, atol=1e-12)


def test_jacobians_match_pinocchio(any_robot):
    """Foot Jacobians = pin.getFrameJacobian(LOCAL_WORLD_ALIGNED); CoM Jacobian = jacobianCenterOfMass."""
    robot = any_robot
    model, data = robot.model, robot.model.createData()
    Q = random_configurations(robot, np.random.default_rng(11), 5)
    kin = robot.kinematics(Q)
    for i, q in enumerate(Q):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for k, leg in enumerate(robot.legs):
            ref = pin.getFrameJacobian(model, data, leg.foot_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
            np.testing.assert_allclose(kin.foot_jacobians[i, k], ref, atol=1e-12)
        np.testing.assert_allclose(kin.com_jacobian[i], pin.jacobianCenterOfMass(model, data, q, False),
                                   atol=1e-12)


def _all_points(robot, Q):
    return np.concatenate([robot.foot_positions(Q), robot.sphere_centres(Q), robot.com(Q)[:, None]], axis=1)


def _all_jacobians(robot, Q):
    return np.concatenate([robot.foot_jacobians(Q), robot.sphere_jacobians(Q),
                           robot.com_jacobian(Q)[:, None]], axis=1)


def test_jacobians_by_finite_differences_in_tangent_space(any_robot):
    """(f(integrate(q, h e_k)) - f(integrate(q, -h e_k))) / 2h ≈ J_v[:, k] for feet, spheres and CoM."""
    robot = any_robot
    Q = random_configurations(robot, np.random.default_rng(12), 3)
    jac = _all_jacobians(robot, Q)
    h = 1e-6
    for i, q in enumerate(Q):
        steps = np.eye(robot.nv) * h
        plus = np.array([pin.integrate(robot.model, q, s) for s in steps])
        minus = np.array([pin.integrate(robot.model, q, -s) for s in steps])
        fd = (_all_points(robot, plus) - _all_points(robot, minus)) / (2 * h)   # (nv, p, 3)
        np.testing.assert_allclose(jac[i], np.moveaxis(fd, 0, -1), atol=1e-7)


def test_jacobians_by_finite_differences_in_vector_space(any_robot):
    """J_x = J_v @ tangent_map(X) against central differences through from_vector."""
    robot = any_robot
    X = robot.to_vector(random_configurations(robot, np.random.default_rng(13), 3))
    jac_x = np.einsum("npkv,nvx->npkx", _all_jacobians(robot, robot.from_vector(X)), robot.tangent_map(X))
    h = 1e-6
    for i, x in enumerate(X):
        steps = np.eye(robot.nx) * h
        fd = (_all_points(robot, robot.from_vector(x + steps))
              - _all_points(robot, robot.from_vector(x - steps))) / (2 * h)
        np.testing.assert_allclose(jac_x[i], np.moveaxis(fd, 0, -1), atol=1e-7)


def test_feet_alone_equal_the_full_batch(any_robot):
    """`feet` (leg IK's evaluation) gives the full batch's foot numbers bit for bit, and leaves its cache."""
    robot = any_robot
    Q = random_configurations(robot, np.random.default_rng(12), 7)
    kin = robot.kinematics(Q)
    feet, jacobians = robot.feet(Q)
    assert np.array_equal(feet, kin.foot_positions) and np.array_equal(jacobians, kin.foot_jacobians)
    positions, none = robot.feet(Q[:3], jacobians=False)
    assert none is None and np.array_equal(positions, kin.foot_positions[:3])
    assert robot.kinematics(Q) is kin


def test_cached_batches_are_consistent(scarab2):
    rng = np.random.default_rng(14)
    Q1, Q2 = random_configurations(scarab2, rng, 4), random_configurations(scarab2, rng, 4)
    first = scarab2.foot_positions(Q1).copy()
    jac = scarab2.foot_jacobians(Q1)
    assert scarab2.foot_jacobians(Q1) is jac                     # one pass for one batch
    np.testing.assert_allclose(scarab2.foot_positions(Q1), first)
    assert not np.allclose(scarab2.foot_positions(Q2), first)   # a new batch is recomputed
    np.testing.assert_allclose(scarab2.foot_positions(Q2[:1]), scarab2.foot_positions(Q2)[:1])
    with pytest.raises(ValueError):
        jac[0, 0, 0, 0] = 1.0                                    # results are read-only


def test_sphere_distances_against_fcl(scarab2):
    """FCL spheres placed by pinocchio's oMf: distance to a ground box and between spheres."""
    robot = scarab2
    Q = random_configurations(robot, np.random.default_rng(15), 4)
    Q[:, 2] += 0.8                                              # well above the ground
    centres = robot.sphere_centres(Q)
    radii = robot.spheres.radii
    ground = fcl.CollisionObject(fcl.Box(10.0, 10.0, 1.0), fcl.Transform(np.array([0.0, 0.0, -0.5])))
    data = robot.model.createData()
    for i, q in enumerate(Q):
        pin.framesForwardKinematics(robot.model, data, q)
        objects = []
        for f, offset, r in zip(robot.spheres.frame_ids, robot.spheres.offsets, radii):
            placement = data.oMf[int(f)] * pin.SE3(np.eye(3), offset)
            objects.append(fcl.CollisionObject(fcl.Sphere(r), fcl.Transform(placement.rotation,
                                                                            placement.translation)))
        ground_distance = np.array([fcl.distance(o, ground, fcl.DistanceRequest(), fcl.DistanceResult())
                                    for o in objects])
        np.testing.assert_allclose(ground_distance, centres[i, :, 2] - radii, atol=1e-6)
        for a, b in [(0, 5), (4, 11), (6, 27), (10, 20)]:
            expected = np.linalg.norm(centres[i, a] - centres[i, b]) - radii[a] - radii[b]
            if expected > 1e-3:                                  # FCL reports separation distances
                got = fcl.distance(objects[a], objects[b], fcl.DistanceRequest(), fcl.DistanceResult())
                np.testing.assert_allclose(got, expected, atol=1e-6)


def test_attached_points_are_the_einsum_bit_for_bit():
    """Points attached to joints, written out per column, give numpy's einsum numbers exactly (the
    planners' results do not change with the formula)."""
    from legplan.robots.kinematics import _attached

    rng = np.random.default_rng(15)
    for n, p in ((1, 1), (7, 40), (33, 53)):
        H = rng.normal(size=(n, p, 4, 4)) * rng.uniform(0.1, 10.0)
        offsets = rng.normal(size=(p, 3))
        expected = np.einsum("npij,pj->npi", H[..., :3, :3], offsets) + H[..., :3, 3]
        assert np.array_equal(_attached(H, offsets), expected)


def test_one_dof_axis_is_the_motion_of_a_small_turn(any_robot):
    """Each leg joint's axis from pinocchio's joint model is the direction its frame turns about (or
    moves along) when only that joint moves; the free flyer is not a one-dof joint."""
    model, data = any_robot.model, any_robot.model.createData()
    q = pin.neutral(model)
    assert one_dof_axis(model.joints[1], q) is None
    for j in range(2, model.njoints):
        revolute, axis = one_dof_axis(model.joints[j], q)
        pin.forwardKinematics(model, data, q)
        before = data.oMi[j].copy()
        moved = q.copy()
        moved[model.idx_qs[j]] += 1e-6
        pin.forwardKinematics(model, data, moved)
        motion = pin.log6(before.inverse() * data.oMi[j])
        turn, shift = (motion.angular, motion.linear) if revolute else (motion.linear, motion.angular)
        np.testing.assert_allclose(turn / 1e-6, axis, atol=1e-8)
        np.testing.assert_allclose(shift, 0.0, atol=1e-12)
