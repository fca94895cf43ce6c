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
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "trot", 3, 2.0)
    result = plan(task, anymal, flat, DynParams())
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    check = check_trajectory(result.samples, anymal, terrain_map, load_robot("anymal"), node_times=result.problem.form.knots)
    records = [trajectory_record(0, task, result, check), failed_record(1, task, "ValueError: broken")]
    summary = write_traj(tmp_path / "traj.h5", records, {"costs": "none"}, "anymal", anymal.legs)
    attrs, tasks = read_tasks(tmp_path / "traj.h5")
    assert attrs["legs"] == "lf,rf,lh,rh" and len(tasks) == 2
    planned, raised = tasks
    assert planned["success"] and planned["iterations"] == result.solve.iterations
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
