"""Every constraint and cost block of the centroidal problem against finite differences, and the
closed-form cost integrals against numerical quadrature of the sampled splines."""

from dataclasses import replace

import numpy as np
import pytest

from legplan.dyn.costs import CostWeights, integral_costs
from legplan.dyn.euler import body_rates, complex_step, rotation, rotation_derivatives, world_rates
from legplan.dyn.init import heuristic
from legplan.dyn.legs import ChainLegs
from legplan.dyn.problem import PAPER_COSTS, DynParams, DynTask, build_problem
from legplan.dyn.timing import PHASES
from legplan.solve import check_jacobian


def _perturbed(problem, seed=0, scale=0.02):
    rng = np.random.default_rng(seed)
    return {b.name: b.value + scale * rng.standard_normal(b.size) for b in problem.variables}


PALLET_TASK = DynTask((-0.3, 0.1, 0.2), (0.9, 0.0, 0.0), "walk", 2, 3.0)
PALLET_PARAMS = DynParams(costs=PAPER_COSTS, swing_height_min=0.05, base_clearance=0.3, leg_clearance=0.05,
                          towr_swing=True)
# the blocks that sample feet or forces in time, which read the phase durations when optimized
TIMED_CONSTRAINTS = {"dynamics", "dynamics_between", "range_of_motion", "swing_above_terrain", "force", "base_clearance", "last_phase",
                     "leg_clearance"}
TORQUE_LIMITS = (40.0, 40.0, 40.0)  # N m per joint: the pallet problem's legs get the joint-torque polytope
TIMED_COSTS = {"force", "force_rate", "normal_force"}


@pytest.fixture(scope="module")
def anymal_torques(anymal):
    """The ANYmal model with joint torque limits (and the legs' chains they need)."""
    from legplan.robots import load_robot

    return replace(anymal, torque_limits=tuple(np.array(TORQUE_LIMITS) for _ in anymal.legs),
                   leg_chains=ChainLegs.of_robot(load_robot("anymal")))


@pytest.fixture(scope="module")
def pallet_problem(anymal, step):
    return build_problem(PALLET_TASK, anymal, step, PALLET_PARAMS, heuristic)


@pytest.fixture(scope="module")
def timed_pallet_problem(anymal, step):
    """The same problem with the phase durations as variables (`DynParams.optimize_phases`)."""
    return build_problem(PALLET_TASK, anymal, step, replace(PALLET_PARAMS, optimize_phases=True), heuristic)


both_timings = pytest.mark.parametrize("problem_name", ["pallet_problem", "timed_pallet_problem"],
                                       ids=["fixed_timing", "optimize_phases"])


def test_blocks_on_a_trots_phase_aligned_unequal_knots_match_finite_differences(anymal, step):
    """A flying trot's base knots (phase-aligned, short polynomials in every support pair, longer ones
    in the stands and flights): the dynamics rows at the knots and between them and the acceleration
    continuity at every junction of unequal polynomials against finite differences."""
    from legplan.dyn.formulation import unloaded_phases

    flying = DynParams(line_support=None)   # its 0.48 s pairs as scaled, between flights
    problem = build_problem(DynTask((-0.3, 0.0, 0.0), (0.6, 0.0, 0.0), "trot", 2, 2.4), anymal, step, flying, heuristic)
    widths = np.diff(problem.form.knots)
    assert unloaded_phases(problem.form.gait).any() and widths.max() > 1.5 * widths.min()
    values = _perturbed(problem)
    checked = set()
    for k in problem.constraints:
        if k.name in ("dynamics", "dynamics_between", "acceleration_continuity"):
            report = check_jacobian(k.block, {v: values[v] for v in k.block.variables})
            assert report.ok(atol=1e-5, rtol=1e-4), (k.name, report)
            checked.add(k.name)
    assert checked == {"dynamics", "dynamics_between", "acceleration_continuity"}


@both_timings
def test_every_constraint_block_matches_finite_differences(request, problem_name):
    """Every constraint block's Jacobian (the phases' too when optimized) against finite differences."""
    problem = request.getfixturevalue(problem_name)
    values = _perturbed(problem)
    names = set()
    for k in problem.constraints:
        report = check_jacobian(k.block, {v: values[v] for v in k.block.variables})
        assert report.ok(atol=1e-5, rtol=1e-4), (k.name, report)
        names.add(k.name)
    assert {"dynamics", "dynamics_between", "range_of_motion", "stance_on_terrain", "swing_above_terrain", "force",
            "acceleration_continuity", "swing", "swing_height", "base_clearance", "stance_off_edges",
            "leg_clearance"} <= names
    reading = {k.name for k in problem.constraints if PHASES in k.block.variables}
    if problem.timing is None:
        assert not reading and "last_phase" not in names
    else:  # every block of those names reads the durations, no other block does
        assert "last_phase" in names and reading == TIMED_CONSTRAINTS
        assert all(PHASES in k.block.variables for k in problem.constraints if k.name in TIMED_CONSTRAINTS)


@pytest.mark.parametrize("optimize_phases", [False, True], ids=["fixed_timing", "optimize_phases"])
@pytest.mark.parametrize("closed_form", [True, False], ids=["closed_form_ik", "chain_ik"])
def test_joint_torque_block_matches_finite_differences(anymal_torques, step, optimize_phases, closed_form):
    """The joint-torque polytope's rows (through the legs' IK: started from the planar closed form,
    the default on ANYmal's legs, or the chain's damped Gauss–Newton alone) against finite
    differences, at a perturbed guess of a walk onto the step whose every foot the legs reach (the
    IK's derivative is that of the torques only where it solves), and bounded by the torque limits
    less the margin."""
    from legplan.dyn.constraints import _nodes
    from legplan.robots import load_robot

    if not closed_form:
        anymal_torques = replace(anymal_torques, leg_chains=ChainLegs.of_robot(load_robot("anymal"), closed_form=False))
    assert all((c.closed_form is not None) == closed_form for c in anymal_torques.leg_chains.chains)
    params = replace(PALLET_PARAMS, optimize_phases=optimize_phases)
    problem = build_problem(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0), anymal_torques, step, params,
                            heuristic)
    values = _perturbed(problem, seed=2, scale=0.005)
    blocks = [k for k in problem.constraints if k.name == "joint_torque"]
    assert len(blocks) == 4
    for k in blocks:
        block = k.block
        assert (PHASES in block.variables) == optimize_phases
        assert np.allclose(k.upper, np.tile(TORQUE_LIMITS, block.n) * (1 - params.torque_margin)) and np.all(k.lower == -k.upper)
        lin, ang, feet = (_nodes(values[v]) for v in block.variables[:3])
        b = block._in_base(block.base @ ang, block.foot @ feet - block.base @ lin) + block.offset
        chain = anymal_torques.leg_chains.chains[block.leg]
        q = chain.solve(b, anymal_torques.leg_chains.nominal(block.leg, block.n))
        reached, _ = chain.point(chain.kinematics(q), chain.foot_joint, chain.foot_offset)
        assert np.abs(reached - b).max() < 1e-9  # the test's premise: every foot in reach
        # a small step: a sample near a phase end, whose force has a kink there in the durations
        report = check_jacobian(block, {v: values[v] for v in block.variables}, step=1e-6)
        assert report.ok(atol=1e-5, rtol=1e-4), (block.leg, report)


def test_joint_torques_are_the_statics_of_pinocchio(anymal_torques):
    """`ChainLegs.foot_torques` at a foot and force equals pinocchio's Jᵀ f at the joints it returns
    (the foot's frame Jacobian, world-aligned, of the robot with its base at the origin)."""
    import pinocchio as pin

    from legplan.robots import load_robot

    robot = load_robot("anymal")
    rng = np.random.default_rng(3)
    for leg_index, leg in enumerate(robot.legs):
        feet = anymal_torques.nominal_feet[leg_index] + rng.uniform(-0.05, 0.05, (5, 3))
        forces = rng.uniform(-60, 60, (5, 3)) + [0, 0, 200]
        tau, _, d_g, joints = anymal_torques.leg_chains.foot_torques(leg_index, feet, forces,
                                                                     anymal_torques.leg_chains.nominal(leg_index, 5))
        for k in range(5):
            q = pin.neutral(robot.model)
            q[[robot.model.idx_qs[robot.model.getJointId(n)] for n in leg.joint_names]] = joints[k]
            jac = pin.computeFrameJacobian(robot.model, robot.model.createData(), q, leg.foot_frame_id,
                                           pin.LOCAL_WORLD_ALIGNED)[:3, list(6 + np.array(leg.joint_idx))]
            data = robot.model.createData()
            pin.framesForwardKinematics(robot.model, data, q)
            assert np.allclose(data.oMf[leg.foot_frame_id].translation, feet[k], atol=1e-9)
            assert np.allclose(tau[k], jac.T @ forces[k], atol=1e-9)
            assert np.allclose(d_g[k], jac.T, atol=1e-12)


@both_timings
def test_every_cost_block_matches_finite_differences(request, problem_name):
    """Every cost block's Jacobian (the phases' too when optimized) against finite differences."""
    problem = request.getfixturevalue(problem_name)
    values = _perturbed(problem, seed=1)
    names = {term.name for term in problem.costs}
    assert {"base_z_velocity", "base_angular_velocity", "force", "force_rate", "normal_force", "stair_edge",
            "swing_height"} <= names
    for term in problem.costs:
        report = check_jacobian(term.block, {v: values[v] for v in term.block.variables})
        assert report.ok(atol=1e-6, rtol=1e-5), (term.name, report)
    reading = {term.name for term in problem.costs if PHASES in term.block.variables}
    assert reading == (set() if problem.timing is None else TIMED_COSTS)


@pytest.mark.parametrize("perturb", [False, True], ids=["initial", "perturbed_nodes"])
def test_timed_costs_equal_the_fixed_timing_costs_at_the_same_timing(pallet_problem, timed_pallet_problem, perturb):
    """At the gait's own durations the costs of the timed problem (`TimedForceIntegralBlock`: another
    factor of the same quadratic form) equal the fixed-timing problem's, term by term."""
    from legplan.solve.auglag import evaluate_costs

    values = {b.name: b.value.copy() for b in timed_pallet_problem.variables}
    np.testing.assert_allclose(values[PHASES], timed_pallet_problem.timing.initial(), atol=1e-12)
    fixed = {b.name: b.value for b in pallet_problem.variables}
    for name, value in fixed.items():
        np.testing.assert_array_equal(values[name], value)
    if perturb:
        nodes = _perturbed(pallet_problem, seed=4, scale=0.5)
        values.update({name: nodes[name] for name in fixed})
    timed, plain = evaluate_costs(timed_pallet_problem.costs, values), evaluate_costs(pallet_problem.costs, values)
    assert "stance_width" in plain and "stance_width" not in timed  # off while the phases move
    plain.pop("stance_width")
    assert set(timed) == set(plain)
    for name in plain:
        assert timed[name] == pytest.approx(plain[name], rel=1e-9, abs=1e-300), name
    assert sum(timed.values()) == pytest.approx(sum(plain.values()), rel=1e-9)
    assert all(timed[name] > 0 for name in TIMED_COSTS)


def _quadrature(form, values, fn, n=20001):
    t = np.linspace(0.0, form.duration, n)
    return np.trapezoid(fn(t), t)


@pytest.mark.parametrize("term", ["base_z_velocity", "base_angular_velocity", "force", "force_rate", "normal_force"])
def test_integral_costs_equal_quadrature_of_eq_1(pallet_problem, anymal, term):
    form = pallet_problem.form
    wd = 0.3
    weights = CostWeights(**{term: 1.0, "derivative_weight": wd})
    (cost,) = integral_costs(form, weights, anymal.mass)
    block = cost.block
    values = _perturbed(pallet_problem, seed=2)
    r = block.evaluate([values[v] for v in block.variables], False)[0]
    lin, ang = values["base_lin"].reshape(-1, 3), values["base_ang"].reshape(-1, 3)
    forces = values["forces"].reshape(-1, 3)

    def integrand(t):
        if term == "base_z_velocity":
            return sum((form.base_matrix(t, d) @ lin)[:, 2] ** 2 * w for d, w in ((1, 1.0), (2, wd)))
        if term == "base_angular_velocity":
            return sum(np.sum((form.base_matrix(t, d) @ ang) ** 2, axis=1) * w for d, w in ((1, 1.0), (2, wd)))
        total = 0.0
        for leg in range(form.legs):
            f = [form.force_matrix(leg, t, d) @ forces for d in range(3)]
            if term == "force":
                total = total + np.sum(f[0] ** 2, axis=1) + wd * np.sum(f[1] ** 2, axis=1)
            elif term == "force_rate":
                total = total + np.sum(f[1] ** 2, axis=1) + wd * np.sum(f[2] ** 2, axis=1)
            else:  # reference m·g over the feet in stance at the midpoint of each force polynomial
                spline = form.feet[leg].force
                seg = spline.segment_index(t)
                mids = 0.5 * (spline.starts + spline.ends)[seg]
                share = anymal.mass * 9.81 / np.maximum(form.gait.contact(mids).sum(axis=1), 1)
                inside = ~np.array([spline.segments[k].constant for k in seg])
                total = total + inside * ((f[0][:, 2] - share) ** 2 + wd * f[1][:, 2] ** 2)
        return total

    expected = _quadrature(form, values, integrand)
    if term in ("force", "force_rate", "normal_force"):  # force terms integrate f / (m·g)
        expected /= (anymal.mass * 9.81) ** 2
    assert float(r @ r) == pytest.approx(expected, rel=2e-3)


def test_euler_rates_match_rotation_derivative():
    rng = np.random.default_rng(3)
    e, ed, edd = rng.normal(size=(3, 5, 3)) * 0.5
    w, wd = world_rates(e, ed, edd)
    h = 1e-6
    r_dot = (rotation(e + h * ed) - rotation(e - h * ed)) / (2 * h)
    omega_hat = r_dot @ np.transpose(rotation(e), (0, 2, 1))
    assert omega_hat[:, 2, 1] == pytest.approx(w[:, 0], abs=1e-6)
    assert omega_hat[:, 0, 2] == pytest.approx(w[:, 1], abs=1e-6)
    assert omega_hat[:, 1, 0] == pytest.approx(w[:, 2], abs=1e-6)
    w_plus = world_rates(e + h * ed + 0.5 * h * h * edd, ed + h * edd)
    w_minus = world_rates(e - h * ed + 0.5 * h * h * edd, ed - h * edd)
    assert (w_plus - w_minus) / (2 * h) == pytest.approx(wd, abs=1e-5)
    wb = body_rates(e, ed)
    assert np.einsum("nij,nj->ni", rotation(e), wb) == pytest.approx(w)


def test_rotation_derivatives_match_central_differences_and_complex_step():
    e = np.random.default_rng(4).normal(size=(6, 3)) * 1.5
    turns = rotation_derivatives(e)
    h = 1e-6
    for k in range(3):
        step = np.zeros(3)
        step[k] = h
        assert turns[:, k] == pytest.approx((rotation(e + step) - rotation(e - step)) / (2 * h), abs=1e-8)
    _, (exact,) = complex_step(lambda x: rotation(x).reshape(len(x), 9), (e,), (0,))
    assert np.moveaxis(turns, 1, 3).reshape(6, 9, 3) == pytest.approx(exact, abs=1e-14)


def test_body_rate_and_inertial_torque_derivatives_match_central_differences_and_complex_step():
    """`body_rate_derivatives` and `DynamicsBlock.inertial_torque_jacobians` (closed form) against
    central differences of `body_rates` / `inertial_torque`, and against complex step (exact)."""
    from legplan.dyn.constraints import DynamicsBlock
    from legplan.dyn.euler import body_rate_derivatives

    rng = np.random.default_rng(8)
    e, ed, edd = rng.normal(size=(3, 7, 3)) * 1.2
    block = DynamicsBlock.__new__(DynamicsBlock)  # the inertia alone: what the torque reads
    block.inertia = np.array([[0.9, 0.02, -0.05], [0.02, 1.8, 0.01], [-0.05, 0.01, 2.2]])
    stacked = lambda a, b, c: np.hstack(body_rates(a, b, c))
    w, wd, *rates = body_rate_derivatives(e, ed, edd)
    assert np.hstack([w, wd]) == pytest.approx(stacked(e, ed, edd), abs=1e-15)
    torque, torque_jacobians = block.inertial_torque_jacobians(e, ed, edd)
    assert torque == pytest.approx(block.inertial_torque(e, ed, edd), abs=1e-13)
    # per argument: ∂(ω, ω̇)/∂x stacked as rows (ω̇ has no ë-free part), and ∂τ/∂x
    rate_jacobians = [np.concatenate([rates[0], rates[2]], axis=1), np.concatenate([rates[1], rates[3]], axis=1),
                      np.concatenate([np.zeros_like(rates[4]), rates[4]], axis=1)]
    h = 1e-6
    args = (e, ed, edd)
    for m in range(3):
        for k in range(3):
            plus, minus = [a.copy() for a in args], [a.copy() for a in args]
            plus[m][:, k] += h
            minus[m][:, k] -= h
            rate_fd = (stacked(*plus) - stacked(*minus)) / (2 * h)
            torque_fd = (block.inertial_torque(*plus) - block.inertial_torque(*minus)) / (2 * h)
            assert rate_jacobians[m][:, :, k] == pytest.approx(rate_fd, abs=1e-7)
            assert torque_jacobians[m][:, :, k] == pytest.approx(torque_fd, abs=1e-6)
    _, exact = complex_step(block.inertial_torque, args, (0, 1, 2))
    for got, want in zip(torque_jacobians, exact):
        assert got == pytest.approx(want, abs=1e-12)


def test_complex_step_is_exact_for_a_polynomial():
    x = np.array([[1.0, 2.0, 3.0], [0.5, -1.0, 2.0]])
    value, (jac,) = complex_step(lambda a: (a ** 3)[:, :2], (x,), (0,))
    assert value == pytest.approx(x[:, :2] ** 3)
    expected = np.zeros((2, 2, 3))
    for i in range(2):
        expected[i, 0, 0], expected[i, 1, 1] = 3 * x[i, 0] ** 2, 3 * x[i, 1] ** 2
    assert jac == pytest.approx(expected, abs=1e-14)


def test_stance_width_block_matches_finite_differences_and_vanishes_at_the_nominal_stance(anymal, flat):
    """`StanceWidthBlock` against finite differences at a perturbed, yawed point; zero on the
    heuristic's footholds on a straight line (each foothold at its nominal lateral offset from the
    base at its stance's middle), and the lateral shift of one foothold comes back as its residual."""
    from legplan.dyn.costs import StanceWidthBlock
    from legplan.dyn.problem import about_com

    task = DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 2.4)
    problem = build_problem(task, anymal, flat, DynParams(), heuristic)
    block = StanceWidthBlock(problem.form, about_com(anymal).nominal_feet[:, 1])
    values = {v.name: v.value.copy() for v in problem.variables}
    r, _ = block.evaluate([values[v] for v in block.variables], False)
    assert np.abs(r).max() < 1e-9
    feet = values["feet"].reshape(-1, 2, 3)
    node = problem.form.feet[1].stance_nodes[2]
    feet[node, 0, 1] += 0.07
    r, _ = block.evaluate([values[v] for v in block.variables], False)
    assert np.sort(np.abs(r))[-1] == pytest.approx(0.07) and np.sort(np.abs(r))[-2] < 1e-9
    rng = np.random.default_rng(3)
    for name in block.variables:
        values[name] = values[name] + 0.05 * rng.standard_normal(values[name].size)
    values["base_ang"].reshape(-1, 2, 3)[:, 0, 2] += 0.6  # yawed
    report = check_jacobian(block, {v: values[v] for v in block.variables})
    assert report.ok(atol=1e-6, rtol=1e-5), report


def test_joint_torque_rows_alone_equal_the_whole_evaluation_and_leave_the_workspace(anymal_torques, step):
    """`JointTorqueBlock.residual_rows` (the IK of the samples holding the rows alone, the curvature
    probe's evaluation) gives the whole evaluation's values on those rows, and leaves the IK's warm
    start where the last whole evaluation put it; with moving phases it is the whole evaluation
    picked (which moves the warm start as every whole evaluation does)."""
    for optimize_phases in (False, True):
        params = replace(PALLET_PARAMS, optimize_phases=optimize_phases)
        problem = build_problem(DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0), anymal_torques, step,
                                params, heuristic)
        start = _perturbed(problem, seed=2, scale=0.005)
        moved = _perturbed(problem, seed=5, scale=0.005)
        rng = np.random.default_rng(7)
        for k in (k for k in problem.constraints if k.name == "joint_torque"):
            block = k.block
            block.evaluate([start[v] for v in block.variables], True)
            kept = block.joints.q.copy()
            rows = np.sort(rng.choice(block.size, 7, replace=False))
            rows[1] = rows[0] + 1 if rows[0] % block.rows < block.rows - 1 else rows[1]  # two rows of one sample
            rows = np.unique(rows)
            alone = block.residual_rows([moved[v] for v in block.variables], rows)
            assert np.array_equal(block.joints.q, kept) != optimize_phases
            whole = block.evaluate([moved[v] for v in block.variables], False)[0]
            np.testing.assert_allclose(alone, whole[rows], rtol=1e-9, atol=1e-9)
            assert np.abs(whole[rows]).max() > 1.0  # torques (N m), not zeros


def _clearance_alone(b, args):
    alone, gradients = b.rows_at(b.leg, *b._sampled(args), b.radius, True)
    plain = b.rows_at(b.leg, *b._sampled(args), b.radius, False)[0]
    return plain.reshape(-1), alone.reshape(-1), b._jacobians(*gradients, args)


def _force_alone(b, args):
    from legplan.dyn.constraints import _nodes, times

    q, f = times(b.foot, _nodes(args[0])), times(b.force, _nodes(args[1]))
    r, (j_f, j_q) = complex_step(b._rows, (f, q), (0, 1))
    return b._rows(f, q).reshape(-1), r.reshape(-1), [b.foot_jacobian([j_q]), b.force_jacobian([j_f])]


def _terrain_alone(b, args):
    from legplan.dyn.constraints import _nodes, times

    q = times(b.matrix, _nodes(args[0]))
    r, j = b._row_jacobian(q)
    return b._row(q), r, [b.jacobian([j])]


LEG_BATCHES = {"leg_clearance": (_clearance_alone, 0.02), "force": (_force_alone, 0.5),
               "stance_on_terrain": (_terrain_alone, 0.05), "swing_above_terrain": (_terrain_alone, 0.05),
               "stance_off_edges": (_terrain_alone, 0.05)}


@pytest.mark.parametrize("name", list(LEG_BATCHES))
def test_leg_batch_gives_each_leg_its_own_evaluation(pallet_problem, timed_pallet_problem, name):
    """The legs' blocks of one constraint of a fixed-timing problem share one batch (`LegClearanceBatch`,
    `ForceBatch`, `FootTerrainBatch`), one per constraint: each block's rows and Jacobians are bit for
    bit those of the leg evaluated alone, at the guess and at perturbed values (the batch evaluates
    again when the values change, also in place), with rows and Jacobians that are not all zero, so
    that the comparison means something; blocks whose samples move with the phases (phases as
    variables) evaluate alone. The batched Jacobians also match finite differences."""
    alone, scale = LEG_BATCHES[name]
    blocks = [k.block for k in pallet_problem.constraints if k.name == name]
    assert len(blocks) == 4 and all(b.batch is blocks[0].batch and b.batch is not None for b in blocks)
    others = {id(k.block.batch) for k in pallet_problem.constraints
              if k.name != name and getattr(k.block, "batch", None) is not None}
    assert id(blocks[0].batch) not in others
    timed = [k.block for k in timed_pallet_problem.constraints if k.name == name]
    assert timed and all((b.batch is None) == (PHASES in b.variables) for b in timed)
    values = {v.name: v.value.copy() for v in pallet_problem.variables}
    args = [values[v] for v in blocks[0].variables]
    for seed in (None, 1, 2):
        if seed is not None:  # changed in place: the batch must not serve the last values
            for a in args:
                a += scale * np.random.default_rng(seed).standard_normal(a.shape)
        rows = []
        for b in blocks:
            value, jacobians = b.evaluate(args, True)
            plain, _ = b.evaluate(args, False)
            expect_plain, expect_value, expect_jacobians = alone(b, args)
            assert np.array_equal(plain, expect_plain) and np.array_equal(value, expect_value)
            for j, k in zip(jacobians, expect_jacobians, strict=True):
                assert np.array_equal(j.toarray(), k.toarray())
            rows.append(plain)
        assert seed is None or np.ptp(np.concatenate(rows)) > 0.0
        assert sum(abs(j).sum() for b in blocks for j in b.evaluate(args, True)[1]) > 0.0
    for b in blocks:
        report = check_jacobian(b, {v: values[v] for v in b.variables})
        assert report.ok(atol=1e-5, rtol=1e-4), report


@pytest.mark.parametrize("name", ["leg_clearance", "range_of_motion", "force"])
@both_timings
def test_rows_of_some_samples_are_those_of_the_whole_evaluation(request, problem_name, name):
    """`residual_rows` of the leg clearance, range of motion and friction pyramid (the curvature
    probe's rows, from their samples alone; with phases as variables the whole evaluation) gives bit
    for bit the rows of the whole (batched) evaluation: any subset of rows, in any order, twice, at
    the guess and at perturbed values (for the clearance: legs near the pallet, rows below the
    reach)."""
    problem = request.getfixturevalue(problem_name)
    blocks = [k.block for k in problem.constraints if k.name == name]
    assert len(blocks) == 4
    values = {v.name: v.value.copy() for v in problem.variables}
    rng = np.random.default_rng(21)
    for seed in range(3):
        args = [values[v] + (0.03 * rng.standard_normal(values[v].shape) if seed and v != PHASES else 0.0)
                for v in blocks[0].variables]
        for b in blocks:
            whole = b.evaluate(args, False)[0]
            if name == "leg_clearance":
                assert whole.min() < b.distance.reach - b.radius.max()  # some sphere within reach
            assert np.ptp(whole) > 0.0
            for _ in range(4):
                rows = rng.integers(0, b.size, int(rng.integers(1, 12)))
                assert np.array_equal(b.residual_rows(args, rows), whole[rows])
