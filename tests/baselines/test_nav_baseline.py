"""OMPL nav baselines on a wall-with-a-gap grid: paths go round the wall within the limits, and
nav.h5 is read back by the nav package's own reader."""

import h5py
import numpy as np
import pytest

from legplan.artefacts import read_summary
from legplan.baselines.nav import NavBaselineParams, outcome_record, plan_baseline, plan_queries, write_nav_baseline
from legplan.nav.artefact import DENSE_STEP, read_queries

START, GOAL = np.array([1.0, 1.0, 0.0, 0.0]), np.array([5.0, 1.0, 0.0, 0.0])


def _check_trajectory(grid, outcome, params):
    result = outcome.result
    assert result.success, result.reason
    t, p, v, a = result.trajectory.sample(DENSE_STEP / 4)
    assert not grid.lethal_at(p).any()  # never inside the inscribed radius of an obstacle
    assert np.abs(v).max() <= params.v_max + 1e-9 and np.abs(a).max() <= params.a_max + 1e-9
    assert p[:, 1].max() > 2.8  # around the end of the wall
    assert np.linalg.norm(p[0] - START[:2]) < 1e-9


@pytest.mark.parametrize("planner", ["rrtconnect", "rrtstar", "prmstar"])
def test_geometric_planners_reach_the_goal_exactly(wall_grid, planner):
    params = NavBaselineParams(planner=planner, time_budget=0.3)
    outcome = plan_baseline(wall_grid, START, GOAL, params, seed=1)
    _check_trajectory(wall_grid, outcome, params)
    assert outcome.goal_error < 1e-9
    assert 0 < outcome.time_to_first_solution <= outcome.result.planning_time
    waypoints = outcome.result.waypoints
    assert outcome.final_cost == pytest.approx(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum())
    assert outcome.result.trajectory.path_length() == pytest.approx(outcome.final_cost, rel=1e-3)


@pytest.mark.parametrize("planner", ["rrt-control", "kpiece-control"])
def test_control_planners_follow_the_double_integrator(wall_grid, planner):
    params = NavBaselineParams(planner=planner, time_budget=8.0, goal_tolerance=0.5)
    outcome = plan_baseline(wall_grid, START, GOAL, params, seed=2)
    _check_trajectory(wall_grid, outcome, params)
    assert outcome.goal_error <= params.goal_tolerance + 1e-9
    segments = outcome.result.trajectory.segments
    assert np.all(segments[:, 6:8] == 0.0)  # constant acceleration per control
    # each segment ends where the next starts: the propagation is the exact double integrator
    ends = segments[:-1, 0:2] + segments[:-1, 2:4] * segments[:-1, 8:9] + 0.5 * segments[:-1, 4:6] * segments[:-1, 8:9] ** 2
    assert np.allclose(ends, segments[1:, 0:2], atol=1e-9)


def test_blocked_goal_fails_with_the_nav_reason(wall_grid):
    outcome = plan_baseline(wall_grid, START, np.array([3.0, 1.0, 0.0, 0.0]), NavBaselineParams(), seed=0)
    assert not outcome.result.success and outcome.result.reason.startswith("goal in collision (a cell within one cell")


def test_artefact_reads_back_with_the_nav_reader(wall_grid, tmp_path):
    params = NavBaselineParams(planner="rrtconnect", time_budget=0.3, seed=5)
    queries = np.array([np.r_[START, GOAL], np.r_[START, 3.0, 1.0, 0.0, 0.0]])
    outcomes = plan_queries(wall_grid, queries, params)
    out = tmp_path / "nav.h5"
    write_nav_baseline(out, [outcome_record(o, wall_grid) for o in outcomes], params, "jueying_mini")
    with h5py.File(out, "r") as f:
        assert f.attrs["legplan_kind"] == "nav" and f.attrs["planner"] == "ompl-rrtconnect"
        read = read_queries(f)
        summary = read_summary(f)
    assert [q["success"] for q in read] == [True, False]
    assert read[0]["seed"] == 5 and read[1]["seed"] == 6
    assert np.array_equal(read[0]["trajectory"].segments, outcomes[0].result.trajectory.segments)
    assert read[0]["effort"] == pytest.approx(outcomes[0].result.trajectory.effort())
    assert summary["succeeded"][0] == 1 and summary["queries"][0] == 2
