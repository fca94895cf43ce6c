"""The step planner's batch kinematics against pinocchio, and its rows against `legplan.contact.terms`."""

import numpy as np
import pinocchio as pin
import pytest

from legplan.contact.terms import collision_terms, com_terms, joint_limit_terms, stance_foot_terms
from legplan.robots import load_robot
from legplan.stepplan.block import SampleConstraints
from legplan.stepplan.kinematics import ChainKinematics, RobotPoints, planner_kinematics
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import contact_mode

ROBOTS = ("scarab2", "anymal", "jueying_mini")


def _vectors(robot, n, seed):
    """Random vectors x around the nominal stance: every joint moved, base rotations from zero (and below
    the series threshold) up to near π."""
    rng = np.random.default_rng(seed)
    X = np.repeat(robot.to_vector(robot.q_nominal[None]), n, axis=0)
    X[:, :3] += rng.normal(scale=0.5, size=(n, 3))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = np.concatenate([[0.0, 1e-9, 3e-5, np.pi - 1e-6], rng.uniform(0, np.pi, n - 4)])
    X[:, 3:6] = angle[:, None] * axis
    X[:, 6:] += rng.normal(scale=0.8, size=(n, robot.n_joints))
    return X


@pytest.mark.parametrize("name", ROBOTS)
def test_points_and_jacobians_match_pinocchio(name):
    robot = load_robot(name)
    chain = ChainKinematics.of(robot)
    assert chain is not None
    X = _vectors(robot, 40, 1)
    Q = robot.from_vector(X)
    reference = robot.kinematics(Q)  # pinocchio: FK, frame placements, joint Jacobians per configuration
    tangent = robot.tangent_map(X)
    points = chain.points(X)
    np.testing.assert_allclose(points.feet, reference.foot_positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(points.spheres, reference.sphere_centres, rtol=0, atol=1e-12)
    np.testing.assert_allclose(points.com, reference.com, rtol=0, atol=1e-12)
    legs, spheres = robot.n_legs, len(robot.spheres.radii)
    samples = np.repeat(np.arange(len(X)), legs + spheres)
    which = np.tile(np.arange(legs + spheres), len(X))
    jac = chain.jacobians(points, samples, which).reshape(len(X), legs + spheres, 3, robot.nx)
    expected = np.einsum("npav,nvx->npax", np.concatenate([reference.foot_jacobians, reference.sphere_jacobians],
                                                           axis=1), tangent)
    np.testing.assert_allclose(jac, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(chain.com_jacobian(points), np.einsum("nav,nvx->nax", reference.com_jacobian, tangent),
                               rtol=0, atol=1e-12)


def test_jacobians_of_some_pairs_are_those_rows():
    robot = load_robot("scarab2")
    chain = ChainKinematics.of(robot)
    X = _vectors(robot, 9, 2)
    points = chain.points(X)
    rng = np.random.default_rng(3)
    samples, which = rng.integers(0, 9, 17), rng.integers(0, robot.n_legs + len(robot.spheres.radii), 17)
    every = chain.jacobians(points, np.repeat(np.arange(9), 34), np.tile(np.arange(34), 9)).reshape(9, 34, 3, -1)
    np.testing.assert_array_equal(chain.jacobians(points, samples, which), every[samples, which])


class _Spherical:
    """A robot whose tree has a joint `ChainKinematics` does not write out (a spherical joint)."""

    def __init__(self):
        model = pin.Model()
        root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
        model.addJoint(root, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
        self.model, self.nv = model, model.nv


def test_tree_it_does_not_cover_falls_back_to_the_robot_kinematics():
    robot = _Spherical()
    assert ChainKinematics.of(robot) is None
    assert isinstance(planner_kinematics(robot), RobotPoints)


@pytest.mark.parametrize("name", ("scarab2", "anymal"))
def test_rows_are_the_contact_terms(name, step_terrain):
    """Every row of `SampleConstraints` (no swing-foot relaxation) is the hinge of the `legplan.contact.terms`
    constraint on pinocchio's kinematics, value and Jacobian."""
    from legplan.terrain.columns import ColumnDistance

    robot = load_robot(name)
    distance = ColumnDistance.of(step_terrain, 0.2)
    X = _vectors(robot, 12, 5)
    X[:, 3:6] *= 0.1
    X[:, :3] = robot.q_nominal[:3] + np.random.default_rng(6).normal(scale=0.05, size=(12, 3))
    stance = np.zeros(robot.n_legs, bool)
    stance[1:] = True
    footholds = robot.foot_positions(robot.q_nominal[None])[0] + 0.01
    mode = contact_mode(stance, footholds, StepPlanParams())
    rows = SampleConstraints(robot, distance, mode, 1e-3)
    assert isinstance(rows.kinematics, ChainKinematics)
    Xi = 0.002 * np.random.default_rng(7).normal(size=(12, rows.slack_size))
    r, G, S = rows.evaluate(X, Xi, True)
    Q = robot.from_vector(X)
    f, jf = stance_foot_terms(robot, X, mode, Q)
    parts = [(f - Xi, jf)]
    norms = np.linalg.norm(Xi.reshape(12, -1, 3), axis=2)
    parts.append((np.maximum(norms - 1e-3, 0.0), np.zeros(norms.shape + (robot.nx,))))
    for g, jac in (com_terms(robot, X, mode, Q), collision_terms(robot, X, mode, distance, Q),
                   joint_limit_terms(robot, X)):
        parts.append((np.maximum(g, 0.0), jac * (g > 0)[..., None]))
    np.testing.assert_allclose(r, np.concatenate([v for v, _ in parts], axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(G, np.concatenate([j for _, j in parts], axis=1), rtol=0, atol=1e-11)
    assert np.count_nonzero(r[:, rows.slack_size + 4:]) > 10  # inequality rows active, not only zeros
    np.testing.assert_array_equal(rows.residuals(X, Xi), r)
    # the compact rows of the structured normal terms carry the same products
    _, (rc, Gc, Sc) = rows.linearize(X, Xi)
    np.testing.assert_allclose(np.einsum("nmx,nmy->nxy", Gc, Gc), np.einsum("nmx,nmy->nxy", G, G), atol=1e-12)
    np.testing.assert_allclose(np.einsum("nmx,nm->nx", Gc, rc), np.einsum("nmx,nm->nx", G, r), atol=1e-12)
    np.testing.assert_allclose(np.einsum("nmx,nms->nxs", Gc, Sc), np.einsum("nmx,nms->nxs", G, S), atol=1e-12)
    np.testing.assert_allclose(np.einsum("nms,nmt->nst", Sc, Sc), np.einsum("nms,nmt->nst", S, S), atol=1e-12)
    np.testing.assert_allclose(np.einsum("nms,nm->ns", Sc, rc), np.einsum("nms,nm->ns", S, r), atol=1e-12)
