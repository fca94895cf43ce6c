"""traj.h5 records: a planned task and one whose planner raised, written and read back, and /summary."""

import numpy as np
import pytest

from legplan.artefacts import open_artefact, read_summary
from legplan.dyn.artefact import failed_record, read_tasks, trajectory_record, write_traj
from legplan.dyn.planner import plan
from legplan.dyn.problem import DynParams, DynTask
from legplan.robots import load_robot
from legplan.terrain import Grid2D, terrain_from_heightmap
from legplan.validate.trajectory import check_trajectory


def test_records_round_trip_and_summary(anymal, flat, tmp_path):
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0)
    result = plan(task, anymal, flat, DynParams())
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    check = check_trajectory(result.samples, anymal, terrain_map, load_robot("anymal"), node_times=result.problem.form.knots)
    records = [trajectory_record(0, task, result, check), failed_record(1, task, "ValueError: broken")]
    summary = write_traj(tmp_path / "traj.h5", records, {"costs": "none"}, "anymal", anymal.legs)
    attrs, tasks = read_tasks(tmp_path / "traj.h5")
    assert attrs["legs"] == "lf,rf,lh,rh" and len(tasks) == 2
    planned, raised = tasks
    assert check.ok, check.failures()
    assert planned["success"] and planned["solved"] and planned["iterations"] == result.solve.iterations
    np.testing.assert_array_equal(planned["com_offset"], np.zeros(3))
    with open_artefact(tmp_path / "traj.h5", kind="traj") as handle:
        judged = handle["tasks/0000/check"]
        assert judged["base_height"].attrs["bound"] == "lower" and judged["leg_penetration"].attrs["bound"] == "upper"
        assert all("tolerance" in judged[name].attrs for name in judged)
    np.testing.assert_array_equal(planned["samples"]["forces"], result.samples["forces"])
    np.testing.assert_array_equal(planned["nodes"]["feet"]["value"], result.solve.values["feet"])
    spans = planned["nodes"]["base_lin"]["span"]
    np.testing.assert_allclose(spans[:, 0], result.problem.form.knots)
    assert np.all(np.isfinite(planned["nodes"]["feet"]["span"]))
    history = planned["history"]
    assert len(history["violation"]) == result.solve.outer_iterations and history["lm"].dtype.kind == "S"
    assert not raised["success"] and raised["reason"] == "ValueError: broken" and "samples" not in raised
    assert np.isnan(raised["solve_seconds"]) and list(raised["start"]) == [0.0, 0.0, 0.0]
    assert summary["tasks"] == 2 and summary["succeeded"] == 1 and summary["success_rate"] == 0.5
    assert summary["check_base_height"][0] == pytest.approx(check.worst["base_height"])
    with open_artefact(tmp_path / "traj.h5", kind="traj") as handle:
        assert read_summary(handle)["check_passed"][0] == int(check.ok)


def test_a_plan_that_fails_its_check_is_a_failed_task(anymal, flat):
    """A converged plan whose independent check fails is recorded as no success, its reason naming
    the failed metrics with their worst values and bounds before the solver's reason."""
    import dataclasses

    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "walk", 2, 3.0)
    result = plan(task, anymal, flat, DynParams())
    assert result.success
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))
    x, _ = grid.centres()
    ridge = terrain_from_heightmap(np.where(np.abs(x - 0.3) < 0.05, 0.3, 0.0), grid, name="ridge")  # under the trunk
    check = check_trajectory(result.samples, anymal, ridge, load_robot("anymal"), node_times=result.problem.form.knots)
    assert not check.ok
    record = trajectory_record(0, task, result, check)
    assert not record["success"] and record["solved"]
    assert record["reason"].startswith("check: ") and record["reason"].endswith(result.reason)
    assert all(f in record["reason"] for f in check.failures()) and "trunk_penetration" in record["reason"]
    passing = dataclasses.replace(check, passed=dict.fromkeys(check.passed, True))
    assert trajectory_record(0, task, result, passing)["success"]
