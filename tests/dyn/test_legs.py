"""The legs' spheres placed by the robot's own kinematics (`legplan.dyn.legs.ChainLegs`) and the
leg-clearance block on them, with the CoM away from the base origin: against pinocchio, the planar
closed form and finite differences."""

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from legplan.dyn.constraints import LegClearanceBlock
from legplan.dyn.init import heuristic
from legplan.dyn.legs import ChainLegs
from legplan.dyn.problem import DynParams, DynTask, build_problem
from legplan.robots.planar_legs import PlanarLegs, _turn
from legplan.robots import load_robot
from legplan.solve import check_jacobian


@pytest.fixture(scope="module")
def robot():
    return load_robot("anymal")


def _leg_joints(robot, leg, Q):
    ids = [robot.model.getJointId(n) for n in leg.joint_names]
    return Q[:, [robot.model.idx_qs[i] for i in ids]]


def test_chain_spheres_and_ik_match_pinocchio(robot):
    """Random joints: pinocchio's feet in the base frame, handed to the chain's IK from the nominal
    joints, give back the joints, pinocchio's sphere centres, and ∂centre/∂foot equal to central
    differences."""
    legs = ChainLegs.of_robot(robot)
    rng = np.random.default_rng(3)
    Q = np.tile(robot.q_nominal, (6, 1))
    Q[:, :7] = [0, 0, 0, 0, 0, 0, 1]
    Q[:, 7:] += 0.15 * rng.standard_normal((6, Q.shape[1] - 7))
    centres = robot.sphere_centres(Q)
    data = robot.model.createData()
    for k, leg in enumerate(robot.legs):
        feet = []
        for q in Q:
            pin.framesForwardKinematics(robot.model, data, q)
            feet.append(data.oMf[leg.foot_frame_id].translation.copy())
        feet = np.array(feet)
        c, jac, joints = legs.sphere_centres(k, feet, legs.nominal(k, len(Q)))
        np.testing.assert_allclose(joints, _leg_joints(robot, leg, Q), atol=1e-8)
        picked = [s for s in np.flatnonzero(np.asarray(robot.spheres.leg_index) == k) if not robot.spheres.is_foot[s]]
        np.testing.assert_allclose(c, centres[:, picked], atol=1e-9)
        np.testing.assert_allclose(legs.sphere_radius[legs.spheres_of(k)], robot.spheres.radii[picked])
        h = 1e-6
        numeric = np.stack([(legs.sphere_centres(k, feet + h * e, joints)[0]
                             - legs.sphere_centres(k, feet - h * e, joints)[0]) / (2 * h) for e in np.eye(3)], axis=-1)
        np.testing.assert_allclose(jac, numeric, atol=1e-7)


def test_ik_started_on_the_other_knee_side_returns_to_the_robots_side(robot):
    """A warm start with the knee bent the other way (outside the planning limits: where a far
    target once carried the damped steps) is solved again from the nominal joints: the joints come
    back inside the limits, on the nominal knee side, equal to the independent check's IK
    (`leg_reach`) for the same feet, and the foot torques are pinocchio's Jᵀf there."""
    from legplan.robots.legik import leg_reach

    legs = ChainLegs.of_robot(robot)
    k = [leg.name for leg in robot.legs].index("rh")
    leg = robot.legs[k]
    Q = np.tile(robot.q_nominal, (3, 1))
    Q[:, :7] = [0, 0, 0, 0, 0, 0, 1]
    Q[:, 7:] += 0.1 * np.random.default_rng(5).standard_normal((3, Q.shape[1] - 7))
    data = robot.model.createData()
    feet = np.zeros((3, robot.n_legs, 3))
    for n, q in enumerate(Q):
        pin.framesForwardKinematics(robot.model, data, q)
        feet[n] = [data.oMf[other.foot_frame_id].translation for other in robot.legs]
    wrong = _leg_joints(robot, leg, Q).copy()
    wrong[:, 1:] *= -1.0   # HFE and KFE mirrored: the knee bent the other way
    assert np.all((wrong[:, 2] < legs.chains[k].lower[2]) | (wrong[:, 2] > legs.chains[k].upper[2]))
    force = np.array([-40.0, 30.0, 200.0])
    tau, _, _, joints = legs.foot_torques(k, feet[:, k], np.tile(force, (3, 1)), wrong, derivatives=False)
    assert np.all((joints >= legs.chains[k].lower) & (joints <= legs.chains[k].upper))
    np.testing.assert_allclose(joints, _leg_joints(robot, leg, Q), atol=1e-8)
    reach = leg_reach(robot, np.zeros((3, 3)), np.tile(np.eye(3), (3, 1, 1)), feet)
    np.testing.assert_allclose(joints, reach.joints[:, list(leg.joint_idx)], atol=1e-6)
    expected = []
    for q in Q:
        jac = pin.computeFrameJacobian(robot.model, data, q, leg.foot_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
        expected.append(jac[:, list(leg.joint_idx_v)].T @ force)
    np.testing.assert_allclose(tau, np.array(expected), atol=1e-8)


def test_chain_legs_agree_with_the_planar_closed_form(robot):
    """On the planar ANYmal legs the two kinematics place the spheres alike, for feet anywhere in
    their range-of-motion boxes (all reachable, robots/anymal/robot.yaml)."""
    chain, planar = ChainLegs.of_robot(robot), robot.centroidal.leg_kinematics
    rng = np.random.default_rng(5)
    box = robot.centroidal.range_of_motion
    for k in range(4):
        feet = robot.centroidal.nominal_feet[k] + box * rng.uniform(-1.0, 1.0, (50, 3))
        centres, _, _ = chain.sphere_centres(k, feet, chain.nominal(k, len(feet)))
        np.testing.assert_allclose(centres, planar.sphere_centres(k, feet), atol=1e-9)


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (0.04, -0.02, 0.03)])
def test_leg_clearance_jacobian_with_chain_legs_and_com_offset(robot, step, offset):
    """The leg-clearance block on the chain's kinematics, the CoM away from the base origin, against
    finite differences at a perturbed point (base, Euler angles and feet all moved), the front feet
    over the step's edge."""
    model = replace(robot.centroidal, com_offset=np.array(offset), leg_kinematics=ChainLegs.of_robot(robot))
    task = DynTask((0.15, 0.0, 0.1), (0.3, 0.0, 0.0), "walk", 2, 3.0)  # short steps: every foot within reach
    problem = build_problem(task, model, step, DynParams(leg_clearance=0.02), heuristic)
    rng = np.random.default_rng(1)
    values = {b.name: b.value + 0.01 * rng.standard_normal(b.size) for b in problem.variables}
    blocks = [k.block for k in problem.constraints if k.name == "leg_clearance"]
    assert len(blocks) == 4 and all(isinstance(b.legs, ChainLegs) for b in blocks)
    for block in blocks[:2]:
        report = check_jacobian(block, {v: values[v] for v in block.variables})
        assert report.ok(atol=1e-5, rtol=1e-4), report


def test_com_offset_keeps_the_range_of_motion_in_the_base_frame(robot, flat):
    """With the CoM 5 cm ahead of the base origin the base spline is the CoM's: the start CoM lies
    5 cm ahead of the task's base pose, and the feet at the nominal stance sit at the centre of their
    boxes (the box offsets are measured from the base origin)."""
    model = replace(robot.centroidal, com_offset=np.array([0.05, 0.0, 0.0]))
    task = DynTask((0.0, 0.0, np.pi / 2), (0.6, 0.0, np.pi / 2), "walk", 2, 3.0)
    problem = build_problem(task, model, flat, DynParams(leg_clearance=None), heuristic)
    np.testing.assert_allclose(problem.start.position[:2], [0.0, 0.05], atol=1e-12)
    np.testing.assert_allclose(problem.com_offset, [0.05, 0.0, 0.0])
    np.testing.assert_allclose(problem.start_feet[:, :2], (model.nominal_feet[:, :2] @ [[0, 1], [-1, 0]]), atol=1e-12)
    block = next(k.block for k in problem.constraints if k.name == "range_of_motion")
    values = {b.name: b.value for b in problem.variables}
    offset = block.evaluate([values[v] for v in block.variables], False)[0].reshape(-1, 3)
    np.testing.assert_allclose(offset[0], 0.0, atol=1e-12)  # t = 0: the nominal stance


def test_a_plan_about_an_offset_com_passes_the_independent_check(robot):
    """A walk of a robot whose CoM lies 4 cm ahead of and 2 cm above its base origin: the plan's
    samples (the base origin's) pass the independent check of the same model, whose Newton–Euler
    residual is taken about the CoM from them — and fail it when the check is told the CoM is at the
    origin (the plan is not one of the origin-centred model)."""
    import dataclasses

    from legplan.dyn.planner import plan
    from legplan.dyn.terrain import TerrainModel
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate.trajectory import check_trajectory

    model = replace(robot.centroidal, com_offset=np.array([0.04, 0.0, 0.02]))
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    terrain = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    result = plan(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0), model, TerrainModel(terrain), DynParams())
    assert result.success, result.reason
    assert result.samples["base_pos"][0] == pytest.approx([0.0, 0.0, model.base_height], abs=1e-9)
    assert result.samples["base_pos"][-1, :2] == pytest.approx([0.6, 0.0], abs=1e-9)
    check = check_trajectory(result.samples, model, terrain, robot, node_times=result.problem.form.knots)
    assert check.ok, check.failures()
    origin = dataclasses.replace(model, com_offset=np.zeros(3))
    wrong = check_trajectory(result.samples, origin, terrain, robot, node_times=result.problem.form.knots)
    assert "newton_euler_torque_nodes" in {f.split()[0] for f in wrong.failures()}


def test_ik_workspace_gives_what_a_fresh_start_gives(robot):
    """A `LegIKData` workspace carried over a sequence of targets (as a block's evaluations move
    its feet): every solve returns the same joints, torques and derivatives as a solve started
    from the workspace's joints alone, to the last bit; the workspace holds the last solve."""
    legs = ChainLegs.of_robot(robot)
    rng = np.random.default_rng(5)
    n, leg = 7, 2
    chain = legs.chains[leg]
    nominal_feet = chain.point(chain.kinematics(legs.nominal(leg, n)), chain.foot_joint, chain.foot_offset)[0]
    data = legs.workspace(leg, n)
    forces = rng.standard_normal((n, 3)) * 100
    for step, derivatives in ((0.0, True), (0.02, False), (0.0, True), (0.05, True), (1e-4, False)):
        feet = nominal_feet + step * rng.standard_normal((n, 3))
        start = data.q.copy()
        fresh = legs.foot_torques(leg, feet, forces, start, derivatives=derivatives)
        kept = legs.foot_torques(leg, feet, forces, data, derivatives=derivatives)
        for a, b in zip(fresh, kept):
            if a is None:
                assert b is None
            else:
                np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(data.q, fresh[3])
        x = chain.point(chain.kinematics(data.q), chain.foot_joint, chain.foot_offset)[0]
        np.testing.assert_allclose(x, feet, atol=1e-12)
    c_fresh = legs.sphere_centres(leg, nominal_feet, data.q.copy())
    c_kept = legs.sphere_centres(leg, nominal_feet, data)
    for a, b in zip(c_fresh, c_kept):
        np.testing.assert_array_equal(a, b)


def test_damped_pinv_as_accurate_as_lapack_near_singular_legs():
    """`_damped_pinv`'s written-out Cholesky inverse of A = J Jᵀ + λI: for well-conditioned J equal to
    LAPACK's to round-off, and for nearly rank-deficient J (a stretched or folded leg, cond(A) up to
    1e10) with a residual ‖A A⁻¹ − I‖ within the backward-stable bound c·cond(A)·ε, as LAPACK's
    own (the cofactor formula misses it by orders of magnitude there)."""
    from legplan.dyn.legs import IK_DAMPING, _damped_pinv, _inverse3

    rng = np.random.default_rng(11)
    for spread in (1.0, 1e-3, 1e-5):
        jac = 0.3 * rng.standard_normal((200, 3, 3))
        jac[:, 2] = jac[:, 0] + spread * jac[:, 2]
        jt = np.swapaxes(jac, 1, 2)
        a = jac @ jt + IK_DAMPING * np.eye(3)
        residual = lambda inverse: np.abs(a @ inverse - np.eye(3)).max(axis=(1, 2))
        lapack, ours = np.linalg.inv(a), _inverse3(a)
        bound = 30 * np.linalg.cond(a) * np.finfo(float).eps
        assert np.all(residual(lapack) <= bound) and np.all(residual(ours) <= bound)
        if spread == 1.0:
            np.testing.assert_allclose(_damped_pinv(jac), jt @ lapack, rtol=1e-8, atol=1e-12)


def _pinocchio_feet(robot, leg, joints):
    """The foot (n, 3) in the base frame by pinocchio's FK at a leg's joints (n, 3), base at the origin."""
    data = robot.model.createData()
    ids = [robot.model.idx_qs[robot.model.getJointId(n)] for n in leg.joint_names]
    feet = []
    for q_leg in joints:
        q = robot.q_nominal.copy()
        q[:7] = [0, 0, 0, 0, 0, 0, 1]
        q[ids] = q_leg
        pin.framesForwardKinematics(robot.model, data, q)
        feet.append(data.oMf[leg.foot_frame_id].translation.copy())
    return np.array(feet)


def _targets(chain, planar, k, rng, n=40):
    """Joints (n·5, 3) the leg takes on its nominal knee side, foot below its HAA axis: spread
    around the nominal stance, and with the knee a fraction 1e-2, 1e-3, 3e-4, 1e-4 of its nominal
    bend from straight (the workspace's outer boundary; the last out of the closed form's reach)."""
    spread = chain.nominal + rng.uniform(-1.0, 1.0, (n, 3)) * [0.3, 0.4, 0.6]
    straight = planar.reference[k, 2] + planar.axis_sign[k, 2] * _turn(planar.thigh_direction[k], *planar.shank_direction[k])
    near = []
    for fraction in (1e-2, 1e-3, 3e-4, 1e-4):
        q = chain.nominal + rng.uniform(-1.0, 1.0, (n, 3)) * [0.3, 0.4, 0.0]
        q[:, 2] = straight + fraction * (chain.nominal[2] - straight)
        near.append(q)
    return np.vstack([spread, *near])


@pytest.mark.parametrize("name", ["anymal", "jueying_mini"])
def test_closed_form_ik_equals_the_chain_ik_and_pinocchio(name):
    """`PlanarLegs.joints` puts pinocchio's foot where asked and equals the chain's damped
    Gauss–Newton from the nominal joints to the IK's resolution: 1e-12 rad inside the workspace,
    1e-8 with the knee 3e-4 of its bend from straight (there the joints move tolerance / b per metre
    of foot, b the knee's offset from the hip-foot line). Feet out of its reach are NaN rows, and
    the chain with the closed form start (the default) gives the pure chain's joints everywhere."""
    robot = load_robot(name)
    planar, pure, started = PlanarLegs.of_robot(robot), ChainLegs.of_robot(robot, closed_form=False), ChainLegs.of_robot(robot)
    assert all(c.closed_form is not None for c in started.chains) and all(c.closed_form is None for c in pure.chains)
    rng = np.random.default_rng(7)
    for k, leg in enumerate(robot.legs):
        chain = pure.chains[k]
        truth = _targets(chain, planar, k, rng)
        feet, _ = chain.point(chain.kinematics(truth), chain.foot_joint, chain.foot_offset)
        np.testing.assert_allclose(feet, _pinocchio_feet(robot, leg, truth), atol=1e-12)  # the chain is the robot's
        closed = planar.joints(k, feet)
        reached = np.isfinite(closed).all(axis=1)
        assert reached[:-40].all() and not reached[-40:].any()  # b² ≤ REACH_FLOOR at 1e-4 of the bend
        np.testing.assert_allclose(_pinocchio_feet(robot, leg, closed[reached]), feet[reached], atol=1e-12)
        np.testing.assert_allclose(closed[:40], truth[:40], atol=1e-12)
        np.testing.assert_allclose(closed[reached], truth[reached], atol=1e-10)
        by_chain = chain.solve(feet, pure.nominal(k, len(feet)))
        np.testing.assert_allclose(by_chain[:40], closed[:40], atol=1e-12)
        np.testing.assert_allclose(by_chain[reached], closed[reached], atol=1e-8)
        np.testing.assert_allclose(started.chains[k].solve(feet, started.nominal(k, len(feet))), by_chain, atol=1e-12)


def test_closed_form_start_takes_the_knee_back_to_the_nominal_side(robot):
    """A warm start on the flipped knee (the other solution for the same feet, outside the planning
    limits): the chain re-solves from the nominal joints, the closed form starts on the nominal
    side; both give the nominal-side joints."""
    from legplan.dyn.legs import LegIKData

    pure, started = ChainLegs.of_robot(robot, closed_form=False), ChainLegs.of_robot(robot)
    rng = np.random.default_rng(11)
    for k in range(4):
        chain = pure.chains[k]
        truth = chain.nominal + rng.uniform(-1.0, 1.0, (30, 3)) * [0.3, 0.3, 0.5]
        feet, _ = chain.point(chain.kinematics(truth), chain.foot_joint, chain.foot_offset)
        guess = truth * [1.0, 0.0, -1.0]  # the knee bent the other way
        flipped = chain._iterate(feet, LegIKData(guess))[0]
        reached, _ = chain.point(chain.kinematics(flipped), chain.foot_joint, chain.foot_offset)
        assert np.abs(reached - feet).max() < 1e-12  # the premise: the other solution, reaching the feet
        assert np.all(np.sign(flipped[:, 2]) == -np.sign(chain.nominal[2]))
        for legs in (pure, started):
            np.testing.assert_allclose(legs.chains[k].solve(feet, flipped.copy()), truth, atol=1e-11)


def test_feet_out_of_reach_keep_the_chains_least_squares_answer(robot):
    """Feet beyond full reach and within the lateral offset of the HAA axis: the closed form has no
    joints (NaN), and the chain with it gives what the pure chain gives from the same start (its
    damped least-squares iterate), the reachable feet in the same batch solved alike."""
    pure, started, planar = ChainLegs.of_robot(robot, closed_form=False), ChainLegs.of_robot(robot), robot.centroidal.leg_kinematics
    rng = np.random.default_rng(13)
    for k in range(4):
        nominal = robot.centroidal.nominal_feet[k]
        haa = planar.haa[k]
        far = haa + 1.6 * (nominal - haa) + rng.uniform(-0.05, 0.05, (10, 3))
        inside = haa + rng.uniform(-0.03, 0.03, (10, 3)) * [1.0, 0.5, 0.5]
        near = nominal + rng.uniform(-0.05, 0.05, (10, 3))
        feet = np.vstack([far, inside, near])
        closed = planar.joints(k, feet)
        assert np.isnan(closed[:20]).all() and np.isfinite(closed[20:]).all()
        start = pure.nominal(k, 30) + 0.1 * rng.standard_normal((30, 3))
        mine = started.chains[k].solve(feet, start.copy())
        np.testing.assert_allclose(mine, pure.chains[k].solve(feet, start.copy()), atol=1e-9)
        np.testing.assert_allclose(mine[20:], closed[20:], atol=1e-12)


def test_foot_torques_with_the_closed_form_start_equal_the_pure_chains(robot):
    """Torques, ∂τ/∂foot and ∂τ/∂force through the closed-form start equal the pure chain's (the
    derivative by the implicit function theorem does not depend on how the joints were found)."""
    pure, started = ChainLegs.of_robot(robot, closed_form=False), ChainLegs.of_robot(robot)
    rng = np.random.default_rng(17)
    for k in range(4):
        feet = robot.centroidal.nominal_feet[k] + rng.uniform(-0.12, 0.12, (25, 3))
        forces = rng.uniform(-60, 60, (25, 3)) + [0, 0, 200]
        want = pure.foot_torques(k, feet, forces, pure.workspace(k, 25))
        got = started.foot_torques(k, feet, forces, started.workspace(k, 25))
        for a, b in zip(got, want):
            np.testing.assert_allclose(a, b, atol=1e-9)
