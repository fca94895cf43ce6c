"""PlanStep on robots loaded through the robot layer (jueying_mini, scarab2), judged independently
by dense re-sampling with pinocchio FK + FCL (`legplan.validate`)."""

import numpy as np
import pytest

from legplan.robots import load_robot
from legplan.stepplan.batch import motion_stance
from legplan.stepplan.measure import dense_check, requirements
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import plan_step, terrain_distance
from legplan.validate.checks import Validator
from scenes import standing_configuration


@pytest.fixture(scope="module")
def scene(box):
    return box.robot, box.terrain, box.map_path, box.q, box.stance, box.footholds


def _plan_and_check(robot, terrain, q, stance_pair, footholds_pair, params=StepPlanParams()):
    stance = motion_stance(*stance_pair, *footholds_pair)
    plan = plan_step(robot, terrain_distance(robot, terrain, params), q[0], q[1], stance, footholds_pair[0], params)
    check = dense_check(robot, Validator(robot, terrain), plan.control_points, stance, footholds_pair[0],
                        1000, requirements(params))
    return plan, check


def test_quadruped_leg_swing_over_box(scene):
    robot, terrain, _, q, stance, footholds = scene
    plan, check = _plan_and_check(robot, terrain, q[1:], stance[1:], footholds[1:])
    assert plan.success, plan.reason
    assert plan.degree >= 2  # the straight line drags the foot through the box
    assert check.foot_slip <= 1.0e-3 + 1e-5  # ε on 1000 dense samples, FK by pinocchio
    assert check.com_margin >= -1e-6 and check.joint_excess <= 1e-9
    assert max(check.shortfalls().values()) <= 0.0  # every constraint kept, clearance with the swing-foot ramp
    line = dense_check(robot, Validator(robot, terrain), np.stack(robot.to_vector(q[1:])), [False, True, True, True],
                       footholds[1], 200, requirements(StepPlanParams()))
    assert line.shortfall_clearance > 0.005  # the straight line drives the foot into the box


def test_step_whose_clearance_is_short_is_reported_failed(scene):
    """An end configuration with the left front shin 2.1 mm inside the 2 cm clearance (IK with no
    clearance): the planner never samples its ends and succeeds, the judge fails the step and names
    the constraint."""
    from legplan.stepplan.batch import StepWorker

    robot, terrain, map_path, q, stance, footholds = scene
    short = standing_configuration(robot, terrain, [-0.03, -0.04, 0.30], footholds[2], clearance=0.0)
    worker = StepWorker(robot.name, str(map_path), StepPlanParams())
    moving = motion_stance(stance[1], stance[2], footholds[1], footholds[2])
    record = worker.plan(1, q[1], short, moving, footholds[1])
    assert not record["success"]
    assert record["reason"].startswith("dense re-check: clearance short by")
    assert record["dense"]["shortfall_clearance"] > 1e-3
    assert record["dense"]["shortfall_foot_slip"] <= 0 and record["dense"]["shortfall_com_margin"] <= 0


def test_quadruped_body_shift_is_a_line(scene):
    robot, terrain, _, q, stance, footholds = scene
    plan, check = _plan_and_check(robot, terrain, q[:2], stance[:2], footholds[:2])
    assert plan.success and plan.degree <= 2
    assert check.foot_slip <= 1.0e-3 + 1e-5 and check.com_margin > 0


def test_hexapod_body_shift(scene):
    robot = load_robot("scarab2")
    terrain = scene[1]
    feet = robot.foot_positions(robot.q_nominal)[0]
    base = robot.q_nominal[:3]
    q = np.stack([standing_configuration(robot, terrain, base, feet),
                  standing_configuration(robot, terrain, base + [0.03, 0.02, -0.01], feet)])
    plan, check = _plan_and_check(robot, terrain, q, np.ones((2, 6), bool), np.stack([feet, feet]),
                                  StepPlanParams(samples=50))
    assert plan.success, plan.reason
    assert check.foot_slip <= 1.0e-3 + 1e-5 and check.com_margin > 0 and check.shortfall_clearance <= 0


def test_unreachable_end_fails_with_reason(scene):
    robot = load_robot("scarab2")
    q0 = robot.q_nominal.copy()
    feet = robot.foot_positions(q0)[0]
    q1 = q0.copy()
    q1[2] -= 0.01  # body 1 cm lower with the same joints: all six feet 1 cm below their footholds
    plan = plan_step(robot, scene[1].sdf, q0, q1, np.ones(6, bool), feet, StepPlanParams(samples=30, max_degree=3))
    assert not plan.success and "ε_num" in plan.reason
    assert [d.degree for d in plan.degrees] == [1, 2, 3]


def test_values_only_path_matches_full_evaluation(scene):
    from legplan.geometry.bezier import elevate
    from legplan.stepplan.block import SampleConstraints
    from legplan.stepplan.planner import contact_mode, path_vectors

    robot, terrain, _, q, _, footholds = scene
    stance = np.array([False, True, True, True])
    x0, x1 = path_vectors(robot, q[1], q[2])
    ends = robot.sphere_centres(robot.from_vector(np.stack([x0, x1])))
    sc = SampleConstraints(robot, terrain.sdf, contact_mode(stance, footholds[1], StepPlanParams()), 1e-3,
                           swing_ends=ends)
    X = elevate(np.stack([x0, x1]), 5) + 0.01 * np.random.default_rng(0).normal(size=(7, robot.nx))
    Xi = 0.002 * np.random.default_rng(1).normal(size=(7, sc.slack_size))
    full = sc.evaluate(X, Xi, True)[0]
    values = sc.evaluate(X + 0.0, Xi, False)[0]
    assert np.count_nonzero(full) > 10
    assert np.allclose(values, full, atol=1e-12)


def test_block_jacobian_on_quadruped_matches_finite_differences(scene):
    from legplan.geometry.bezier import elevate
    from legplan.solve import check_jacobian
    from legplan.stepplan.block import BezierConstraintBlock, SampleConstraints
    from legplan.stepplan.planner import contact_mode, path_vectors

    robot, terrain, _, q, _, footholds = scene
    stance = np.array([False, True, True, True])
    x0, x1 = path_vectors(robot, q[1], q[2])
    ends = robot.sphere_centres(robot.from_vector(np.stack([x0, x1])))
    sc = SampleConstraints(robot, terrain.sdf, contact_mode(stance, footholds[1], StepPlanParams()), 1e-3,
                           swing_ends=ends)
    block = BezierConstraintBlock(sc, 3, np.linspace(0, 1, 7)[1:-1])
    rng = np.random.default_rng(5)
    P = elevate(np.stack([x0, x1]), 2) + 0.01 * rng.normal(size=(4, robot.nx))
    xi = 0.002 * rng.normal(size=5 * sc.slack_size)
    r, _ = block.evaluate([P.reshape(-1), xi], False)
    assert np.count_nonzero(r) > 20
    report = check_jacobian(block, [P.reshape(-1), xi], step=1e-7)
    assert report.ok(atol=1e-5, rtol=1e-3), report


def test_linearization_from_the_rows_at_hand_is_the_full_one(scene):
    """`SampleConstraints.linearize` given the rows it would compute (an accepted LM trial's) forms the
    terrain gradients and swing-foot ramps of the active collision rows only: the same r, G, S bit for bit,
    with active rows of relaxed swing-foot spheres and of other spheres among them."""
    from legplan.geometry.bezier import elevate
    from legplan.stepplan.block import SampleConstraints
    from legplan.stepplan.planner import contact_mode, path_vectors

    robot, terrain, _, q, _, footholds = scene
    params = StepPlanParams()
    stance = np.array([False, True, True, True])
    x0, x1 = path_vectors(robot, q[1], q[2])
    ends = robot.sphere_centres(robot.from_vector(np.stack([x0, x1])))
    sc = SampleConstraints(robot, terrain_distance(robot, terrain, params), contact_mode(stance, footholds[1], params),
                           1e-3, swing_ends=ends, relax_radius=params.relax_radius,
                           headroom=params.sample_clearance - params.clearance)
    rng = np.random.default_rng(3)
    X = elevate(np.stack([x0, x1]), 12) + 0.01 * rng.normal(size=(14, robot.nx))
    X[:, 2] -= np.linspace(0.0, 0.08, 14)  # sinking: more and more spheres within their clearance
    Xi = 0.002 * rng.normal(size=(14, sc.slack_size))
    points = sc.kinematics.points(X)
    r = sc.residuals(X, Xi, points)
    computed = sc.linearize(X, Xi, points)
    given = sc.linearize(X, Xi, points, r)
    collision = r[:, 4 * stance.sum() + len(sc.mode.polygon.b):][:, :len(sc.checked)] > 0
    assert collision[:, sc.relaxed_rows].any()
    assert np.delete(collision, sc.relaxed_rows, axis=1).any()
    assert np.array_equal(computed[0], given[0]) and np.array_equal(computed[0], r)
    for a, b in zip(computed[1], given[1]):
        assert np.array_equal(a, b)
