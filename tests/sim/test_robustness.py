"""The stricter simulator (issue 34 items 5 and 6): unsolved plans skipped, joint velocity limits,
the QP fallback, pushes, friction and mass scale."""

import h5py
import mujoco
import numpy as np
import pytest
from click.testing import CliRunner
from stance import standing

from legplan.artefacts.reader import read_summary
from legplan.cli.main import cli
from legplan.dyn.artefact import read_tasks
from legplan.dyn.terrain import TerrainModel
from legplan.sim.controller import WholeBodyController
from legplan.sim.items import SimWorker, sim_items, simulate_item
from legplan.sim.model import ModelOptions, build_model
from legplan.sim.reference import Reference
from legplan.sim.run import (CONTROL_DT, OVERSPEED, SimParams, _initial_state, _pinocchio_state, perturb, simulate,
                             touching)


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_an_unsolved_plan_is_skipped_not_executed(flat, two_tasks, tmp_path):
    out = tmp_path / "sim.h5"
    result = invoke("dyn", "simulate", two_tasks, flat[1], "-o", out)
    assert result.exit_code == 1, result.output
    with h5py.File(out) as handle:
        solved, unsolved = handle["tasks/0000"], handle["tasks/0001"]
        assert solved.attrs["planned"] and not solved.attrs["skipped"] and solved.attrs["success"]
        assert not unsolved.attrs["planned"] and unsolved.attrs["skipped"] and not unsolved.attrs["success"]
        assert unsolved.attrs["reason"].startswith("skipped: the plan did not succeed (")
        assert np.isnan(unsolved.attrs["simulated"]) and "series" not in unsolved   # never executed
        summary = read_summary(handle)
        assert summary["skipped"][0] == 1 and summary["succeeded"][0] == 1 and summary["qp_failures"][0] == 0
    # the unsolved task has samples: skipping is the rule, not a missing trajectory
    _, tasks = read_tasks(two_tasks)
    assert not tasks[1]["success"] and "samples" in tasks[1]
    worker = SimWorker("anymal", str(flat[1]), SimParams())
    record = simulate_item(worker, sim_items(tasks)[1])
    assert record["skipped"] and np.isnan(record["wall"])


def test_joint_velocity_limits_are_enforced(robot, flat, trot):
    """The trot's joints reach some peak speed freely; with every limit at half of it the motors and
    the controller hold them at the limit: more than 5 % over it only briefly (an impact back-driving
    a knee: the fixture's trot ends with a foot on the block), against for long without the limit."""
    _, tasks = read_tasks(trot)
    samples, goal = tasks[0]["samples"], tasks[0]["goal"]
    free = simulate(samples, robot, flat[0], SimParams(record_every=1), goal=goal)
    assert build_model(robot, flat[0], 0.5).velocity_limit == pytest.approx(8.0)   # the URDF's
    peak = 8.0 * free.peak_speed_ratio
    assert free.success and np.abs(free.series["joint_vel"]).max() == pytest.approx(peak)
    limit = 0.5 * peak
    free_over = CONTROL_DT * np.sum(np.abs(free.series["joint_vel"]).max(axis=1) > OVERSPEED * limit)
    limited = simulate(samples, robot, flat[0], SimParams(model=ModelOptions(velocity=(("*", limit),))), goal=goal)
    assert limited.success, limited.reason
    assert limited.speed_limited_time > 0 and limited.peak_speed_ratio >= 1.0
    assert free_over >= 0.05 and limited.overspeed_time <= free_over / 4


def _standing_tick(robot, flat):
    """The model, the state (q, v), the reference and the feet touching of a robot standing on `flat`
    at its first tick."""
    sim = build_model(robot, flat[0], 0.5)
    reference = Reference(standing(robot, 0.2), sim.foot_radius, TerrainModel(flat[0]))
    data = mujoco.MjData(sim.model)
    _initial_state(data, sim, robot, reference)
    q, v = _pinocchio_state(data, sim)
    return sim, q, v, reference.at(0.0), touching(data, sim)


def test_a_failed_qp_falls_back_to_the_relaxed_qp(robot, flat):
    """A knee at 50 rad/s against its 8 rad/s limit with 1 N m motors: braking it back inside the
    limit within the velocity horizon needs far more torque, so the QP is infeasible; the relaxed
    QP (no velocity rows, stance contact as a task) answers within the torque limits; counted."""
    sim, q, v, ref, feet = _standing_tick(robot, flat)
    fast = v.copy()
    fast[6 + robot.joint_names.index("kfe_lf")] = 50.0
    for effort, rates, failures in ((sim.effort, v, 0), (np.full(robot.n_joints, 1.0), fast, 1)):
        controller = WholeBodyController(robot, effort, 0.5, velocity_limit=sim.velocity_limit)
        tau = controller.torques(q, rates, ref, feet)
        assert controller.qp_failures == failures and controller.qp_held == 0
        assert np.abs(tau).max() <= effort.max() + 1e-9
    assert np.abs(tau).max() > 0.5   # the relaxed QP's torques, not zeros


def test_a_reference_far_off_costs_the_qp_a_bounded_number_of_iterations(robot, flat, monkeypatch):
    """A reference ten orders of magnitude beyond the robot (what a diverged replan would hand over):
    ProxQP stops within `QP_MAX_OUTER` × `QP_MAX_INNER` iterations on each of the tick's QPs (within its
    defaults it runs thousands on every tick), the QP counts as failed and the torques stay within
    their limits; a standing reference solves in a few."""
    from dataclasses import replace

    import proxsuite

    from legplan.sim.controller import QP_MAX_INNER, QP_MAX_OUTER

    solvers = []
    real = proxsuite.proxqp.dense.QP

    def recorded(*shape):
        solvers.append(real(*shape))
        return solvers[-1]
    monkeypatch.setattr(proxsuite.proxqp.dense, "QP", recorded)
    sim, q, v, ref, feet = _standing_tick(robot, flat)
    controller = WholeBodyController(robot, sim.effort, 0.5)
    controller.torques(q, v, ref, feet)
    assert len(solvers) == 1 and solvers[0].results.info.iter < 0.1 * QP_MAX_INNER
    far = replace(ref, acc=ref.acc + [0.0, 1e10, 0.0], omega_dot=ref.omega_dot + [1e10, 0.0, 0.0],
                  forces=ref.forces + 1e10)
    solvers.clear()
    tau = controller.torques(q, v, far, feet)
    assert controller.qp_failures == 1 and len(solvers) == 2
    for solver in solvers:
        assert solver.results.info.iter_ext <= QP_MAX_OUTER
        assert solver.results.info.iter <= QP_MAX_OUTER * QP_MAX_INNER
    assert np.all(np.isfinite(tau)) and np.all(np.abs(tau) <= sim.effort + 1e-9)


def test_joint_damping_is_compensated(robot, flat):
    """With damping d on the joints the controller's torques are those without, plus d v_j (the same
    QP optimum, its torque limits shifted by the damping torque)."""
    sim = build_model(robot, flat[0], 0.5)
    reference = Reference(standing(robot, 0.2), sim.foot_radius, TerrainModel(flat[0]))
    data = mujoco.MjData(sim.model)
    _initial_state(data, sim, robot, reference)
    q, v = _pinocchio_state(data, sim)
    v[6:] = np.linspace(-0.5, 0.5, robot.n_joints)
    ref, feet = reference.at(0.0), touching(data, sim)
    damping = np.full(robot.n_joints, 2.0)
    plain = WholeBodyController(robot, sim.effort, 0.5).torques(q, v, ref, feet)
    damped = WholeBodyController(robot, sim.effort, 0.5, damping=damping).torques(q, v, ref, feet)
    assert np.abs(plain).max() < 0.8 * sim.effort.min()       # no torque limit active
    np.testing.assert_allclose(damped - plain, damping * v[6:], atol=1e-5)


def test_a_lateral_push_moves_the_robot_and_a_large_one_knocks_it_over(robot, flat):
    still = simulate(standing(robot, 1.5), robot, flat[0], SimParams(settle=0.0))
    small = simulate(standing(robot, 1.5), robot, flat[0], SimParams(settle=0.0, pushes=((0.3, 0.0, 100.0, 0.05),)))
    large = simulate(standing(robot, 1.5), robot, flat[0], SimParams(settle=0.0, pushes=((0.3, 0.0, 1500.0, 0.1),)))
    assert small.impulse == pytest.approx(5.0) and large.impulse == pytest.approx(150.0)
    assert still.success and small.success, small.reason
    lateral = lambda r: np.abs(r.series["base_vel"][:, 1]).max()
    assert lateral(still) < 0.01 and lateral(small) > 0.05    # the push moved the base sideways
    assert large.fell and not large.success


def test_mass_and_friction_scale_change_the_simulated_robot_only(robot, flat):
    heavy = simulate(standing(robot, 0.5), robot, flat[0], SimParams(settle=0.0, mass_scale=1.2))
    assert heavy.success
    weight = heavy.series["foot_forces"][-1][:, 2].sum()
    assert weight == pytest.approx(1.2 * robot.mass * 9.81, rel=0.02)
    sim = build_model(robot, flat[0], 0.5)
    perturb(sim, mujoco.MjData(sim.model), SimParams(friction_scale=0.3))
    assert sim.model.geom_friction[:, 0] == pytest.approx(0.15)
