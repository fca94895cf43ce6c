"""`dyn simulate --replan PERIOD`: the closed loop replans from the simulated state every PERIOD and
records every replan in sim.h5 (issue 39 item 3)."""

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_closed_loop_replans_every_period_and_records_them(flat, tmp_path):
    """A 3 s walk of 2 strides replanned every 0.5 s: 5 replans (none in the last 0.3 s)."""
    traj = tmp_path / "traj.h5"
    planned = invoke("dyn", "plan", flat[1], "--gait", "walk", "--strides", "2", "--duration", "3.0",
                     "--start", "0", "0", "0", "--goal", "0.5", "0.1", "0.1", "-o", traj, "-q")
    assert planned.exit_code == 0, planned.output
    out = tmp_path / "sim.h5"
    result = invoke("dyn", "simulate", traj, flat[1], "--replan", "0.5", "-o", out, "-q")
    with h5py.File(out) as handle:
        task = handle["tasks/0000"]
        replans = {name: task[f"replans/{name}"][()] for name in task["replans"]}
        assert result.exit_code == 0, (result.output, task.attrs["reason"])
        assert task.attrs["success"]
    t = replans["t"]
    assert len(t) == 5 and np.allclose(t, 0.5 * np.arange(1, 6), atol=0.003)
    assert replans["base_pos"].shape == (5, 3) and replans["feet_pos"].shape == (5, 4, 3)
    assert np.all(replans["cpu_seconds"] > 0) and np.all(replans["iterations"] >= 0)
    assert replans["success"].dtype == bool and replans["success"].all()
    assert json_replan(out) == 0.5


def json_replan(path):
    import json
    with h5py.File(path) as handle:
        return json.loads(handle.attrs["params"])["replan"]


def test_closed_loop_survives_a_push_the_open_loop_fails_under(flat, trot):
    """The 1 m flat trot pushed sideways at half its duration (30 N s): executed as planned it
    fails (falls, or is pushed off its goal's heading); replanned every 0.25 s and at once when the push drives the base out of the default
    velocity tube, every replan tracked (the ones that did not converge too: they start from where
    the push left the robot; every one before the push converges), it reaches the goal. No replan
    stalls: the front feet land by the block's edge, and a foothold a solve moves onto the edge's
    crest is moved off it again (`TerrainModel.stance_slope`'s gradient there)."""
    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan_io import recorded_params
    from legplan.sim.items import SimWorker, sim_items, simulate_item
    from legplan.sim.run import SimParams

    attrs, tasks = read_tasks(trot)
    item = sim_items(tasks)[0]
    params = SimParams(pushes=((1.2, 0.0, 300.0, 0.1),))
    dyn = recorded_params(json.loads(attrs["params"]))
    opened = simulate_item(SimWorker("anymal", str(flat[1]), params), item)
    closed = simulate_item(SimWorker("anymal", str(flat[1]), params, replan=(0.25, dyn)), item)
    assert not opened["success"] and opened["reason"].startswith(("fell", "missed the goal")), opened["reason"]
    assert closed["success"], closed["reason"]
    replans = closed["replans"]
    assert replans["success"].size >= 7 and replans["success"][replans["t"] < 1.2].all()  # before the push
    assert replans["tracked"].all() and not replans["success"].all()
    assert b"stalled" not in set(replans["status"]), replans["status"]
    assert np.all(replans["cpu_seconds"] > 0) and np.all(replans["violation"] >= 0)
    pushed = replans["t"][replans["trigger"] == b"tube"]
    assert pushed.size and 1.2 < pushed[0] <= 1.31  # answered by the push's end, not at the next period (1.5 s)


def test_an_unconverged_replan_is_tracked_when_near_feasible(flat, trot):
    """A replan cut at one LM iteration (MAX_ITERATIONS) from a pushed state: recorded as not
    converged either way; handed to the controller when its scaled violation is within
    `track_violation` (just above it, or inf), not when it exceeds it (just below it, or 0)."""
    import pinocchio as pin

    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan import Previous, ReplanParams
    from legplan.dyn.replan_io import recorded_params
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner

    attrs, tasks = read_tasks(trot)
    params = recorded_params(json.loads(attrs["params"]))
    model = centroidal_model(load_robot("anymal"), params)
    samples = tasks[0]["samples"]
    k = int(np.argmin(np.abs(samples["t"] - 0.5)))
    rot = pin.rpy.rpyToMatrix(*samples["base_euler"][k])
    state = (samples["base_pos"][k], rot, samples["base_vel"][k] + [0.0, 0.4, 0.0], samples["base_ang_vel"][k],
             samples["feet_pos"][k])

    def run(bound):
        settings = ReplanParams(max_iterations=1, track_violation=bound)
        replanner = Replanner(Previous.from_record(tasks[0], model.com_offset, params.dt), model,
                              TerrainModel(flat[0]), params, 0.5, settings)
        handed = replanner(float(samples["t"][k]), *state)
        columns = replanner.columns()
        assert columns["success"].tolist() == [False] and columns["iterations"].tolist() == [1]
        assert columns["tracked"].tolist() == [handed is not None]
        return handed, float(columns["scaled_violation"][0])

    handed, scaled = run(np.inf)
    assert handed is not None and scaled > 0.0
    assert np.allclose(handed["base_vel"][0], state[2], atol=1e-9)
    assert handed["t"][0] == samples["t"][k]
    assert run(1.01 * scaled)[0] is not None
    assert run(0.99 * scaled)[0] is None
    assert run(0.0)[0] is None


def test_a_replan_is_due_when_the_base_leaves_the_tube(flat, trot):
    """Event-triggered replans: with the tube off only the period; with a tube, a position or velocity
    error beyond it makes a replan due at once, not again within `trigger_gap`, and the period
    restarts at it; the replan's row records its trigger and why its solve stopped."""
    import pinocchio as pin

    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan import Previous, ReplanParams
    from legplan.dyn.replan_io import recorded_params
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner

    attrs, tasks = read_tasks(trot)
    params = recorded_params(json.loads(attrs["params"]))
    model = centroidal_model(load_robot("anymal"), params)

    def replanner(**settings):
        return Replanner(Previous.from_record(tasks[0], model.com_offset, params.dt), model, TerrainModel(flat[0]),
                         params, 0.5, ReplanParams(**settings))

    off = replanner(tube_velocity=None)
    assert off.due(0.3, 1.0, 5.0) is None and off.due(0.5) == "period"
    assert replanner().due(0.3, 0.0, 5.0) == "tube"  # the default watches the velocity
    tube = replanner(tube_position=0.05, tube_velocity=0.2, trigger_gap=0.1)
    assert tube.due(0.3, 0.04, 0.19) is None
    assert tube.due(0.3, 0.06, 0.0) == "tube" and tube.due(0.3, 0.0, 0.21) == "tube"
    samples = tasks[0]["samples"]
    k = int(np.argmin(np.abs(samples["t"] - 0.3)))
    t = float(samples["t"][k])
    handed = tube(t, samples["base_pos"][k], pin.rpy.rpyToMatrix(*samples["base_euler"][k]),
                  samples["base_vel"][k] + [0.0, 0.3, 0.0], samples["base_ang_vel"][k], samples["feet_pos"][k],
                  "tube")
    assert handed is not None
    assert tube.due(t + 0.09, 0.0, 1.0) is None and tube.due(t + 0.11, 0.0, 1.0) == "tube"
    assert tube.due(t + 0.49) is None and tube.due(t + 0.5) == "period"
    columns = tube.columns()
    assert columns["trigger"].tolist() == [b"tube"]
    assert columns["status"][0] in (b"converged", b"max_iterations", b"stalled")
    assert (columns["status"][0] == b"converged") == bool(columns["success"][0])


def test_replan_parameters_on_the_command_line(flat, trot, tmp_path):
    """`dyn simulate --param` sets `ReplanParams` of the closed loop: refused without --replan and out
    of its range or unknown (exit 2, nothing written)."""
    out = tmp_path / "sim.h5"
    alone = invoke("dyn", "simulate", trot, flat[1], "--param", "tube_velocity=0.3", "-o", out, "-q")
    assert alone.exit_code == 2 and "--replan" in alone.output and not out.exists()
    bad = invoke("dyn", "simulate", trot, flat[1], "--replan", "0.5", "--param", "tube_velocity=-1", "-o", out, "-q")
    assert bad.exit_code == 2 and "tube_velocity" in bad.output and not out.exists()
    unknown = invoke("dyn", "simulate", trot, flat[1], "--replan", "0.5", "--param", "tube=1", "-o", out, "-q")
    assert unknown.exit_code == 2 and "tube" in unknown.output and not out.exists()


def test_the_worker_hands_its_replan_parameters_to_the_closed_loop(flat, trot):
    """`dyn simulate --replan --param` reaches the `Replanner` through the batch worker."""
    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan import ReplanParams
    from legplan.dyn.replan_io import recorded_params
    from legplan.sim.items import SimWorker
    from legplan.sim.run import SimParams

    attrs, tasks = read_tasks(trot)
    dyn = recorded_params(json.loads(attrs["params"]))
    chosen = ReplanParams(tube_velocity=None, tube_position=0.04, max_iterations=7)
    worker = SimWorker("anymal", str(flat[1]), SimParams(), replan=(0.25, dyn, chosen))
    assert worker.replanner(tasks[0]).settings == chosen
    default = SimWorker("anymal", str(flat[1]), SimParams(), replan=(0.25, dyn))
    assert default.replanner(tasks[0]).settings == ReplanParams()


def test_a_replan_out_of_cpu_time_is_recorded_and_a_non_finite_plan_is_never_tracked(flat, trot):
    """A replan stopped by `ReplanParams.cpu_budget` before its first LM step: recorded as
    `time_limit` with no iteration and, from the measured state, handed to the controller as one
    out of iterations is (`track_violation`); a plan with a value that is not finite is never
    handed over, whatever `track_violation` allows (the controller keeps its reference)."""
    import pinocchio as pin

    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan import MeasuredState, Previous, ReplanParams, replan
    from legplan.dyn.replan_io import recorded_params
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner, trackable

    attrs, tasks = read_tasks(trot)
    params = recorded_params(json.loads(attrs["params"]))
    model = centroidal_model(load_robot("anymal"), params)
    samples = tasks[0]["samples"]
    k = int(np.argmin(np.abs(samples["t"] - 0.5)))
    pushed = samples["base_vel"][k] + [0.0, 0.4, 0.0]
    previous = Previous.from_record(tasks[0], model.com_offset, params.dt)
    replanner = Replanner(previous, model, TerrainModel(flat[0]), params, 0.5, ReplanParams(cpu_budget=1e-9))
    handed = replanner(float(samples["t"][k]), samples["base_pos"][k], pin.rpy.rpyToMatrix(*samples["base_euler"][k]),
                       pushed, samples["base_ang_vel"][k], samples["feet_pos"][k])
    columns = replanner.columns()
    assert columns["status"].tolist() == [b"time_limit"] and columns["iterations"].tolist() == [0]
    assert columns["tracked"].tolist() == [True] and not columns["success"][0]
    assert handed is not None and np.allclose(handed["base_vel"][0], pushed, atol=1e-9)

    state = MeasuredState(float(samples["t"][k]), samples["base_pos"][k], samples["base_euler"][k], pushed,
                          samples["base_ang_vel"][k], samples["feet_pos"][k])
    out = replan(previous, state, model, TerrainModel(flat[0]), params, settings=ReplanParams(max_iterations=1))
    assert trackable(out, np.inf)
    out.plan.samples["forces"][3, 0, 2] = np.nan
    assert not trackable(out, np.inf)


def test_a_closed_loop_whose_replan_inserts_strides_runs_to_the_later_end(flat, trot):
    """`ReplanParams.extension`: the flat trot pushed hard sideways; the recovering replan inserts
    strides, recorded in sim.h5's `extension` column, and the run goes on to the end of the longer
    plan and its settle instead of the first plan's."""
    from legplan.dyn.artefact import read_tasks
    from legplan.dyn.replan import ReplanParams
    from legplan.dyn.replan_io import recorded_params
    from legplan.sim.items import SimWorker, sim_items, simulate_item
    from legplan.sim.run import CONTROL_DT, SimParams

    attrs, tasks = read_tasks(trot)
    item = sim_items(tasks)[0]
    dyn = recorded_params(json.loads(attrs["params"]))
    params = SimParams(pushes=((1.2, 0.0, 300.0, 0.1),))
    closed = simulate_item(SimWorker("anymal", str(flat[1]), params, replan=(0.25, dyn, ReplanParams(extension=1.2))),
                           item)
    replans = closed["replans"]
    added = float(replans["extension"].sum())
    assert 0.5 < added <= 1.2 + 1e-9 and replans["extension"][replans["tracked"]].sum() == added
    end = tasks[0]["samples"]["t"][-1] + added + params.settle
    if not closed["fell"]:
        assert closed["series"]["t"][-1] == pytest.approx(end, abs=2 * CONTROL_DT), closed["reason"]
    else:
        assert closed["series"]["t"][-1] > tasks[0]["samples"]["t"][-1] + params.settle, closed["reason"]


def test_the_simulator_hands_a_replan_the_feet_it_senses_on_the_ground(flat, trot):
    """`simulate` gives the replanner the feet the simulation has in contact (`MeasuredState.contact`,
    what `legplan.dyn.replan.lifted_feet` reads): mid-stance of the trot's first pair, that pair."""
    from legplan.dyn.artefact import read_tasks
    from legplan.robots import load_robot
    from legplan.sim.run import SimParams, simulate

    _, tasks = read_tasks(trot)
    samples = tasks[0]["samples"]
    sensed = []

    class Stop(Exception):
        pass

    class Recorder:
        def due(self, t, position_error=0.0, velocity_error=0.0):
            return "period" if t >= 0.3 else None

        def __call__(self, t, base_pos, base_rot, base_vel, base_ang_vel, feet_pos, trigger="period", contact=None):
            sensed.append((t, contact))
            raise Stop

    with pytest.raises(Stop):
        simulate(samples, load_robot("anymal"), flat[0], SimParams(), replanner=Recorder())
    (t, contact), = sensed
    k = int(np.argmin(np.abs(samples["t"] - t)))
    planned = np.asarray(samples["contact"][k], bool)
    assert 0 < planned.sum() < 4 and np.array_equal(contact, planned)
