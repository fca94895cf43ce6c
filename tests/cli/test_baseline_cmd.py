"""`legplan baseline nav|step` end to end: artefacts, exit codes 0 / 1 (failed items) / 2 (bad input)."""

import h5py
import pytest
from click.testing import CliRunner

from legplan.artefacts import read_summary
from legplan.cli.main import cli
from legplan.stepplan.batch import read_motion


@pytest.fixture(scope="module")
def wall(tmp_path_factory, wall_map):
    return tmp_path_factory.mktemp("baselinecli"), wall_map


def test_nav_writes_a_nav_artefact(wall):
    tmp, map_path = wall
    out = tmp / "nav.h5"
    result = CliRunner().invoke(cli, ["baseline", "nav", str(map_path), "--start", "1", "1", "--goal", "5", "1",
                                      "--planner", "rrtstar", "--time-budget", "0.2", "--seed", "4", "-o", str(out)])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out, "r") as f:
        assert f.attrs["legplan_kind"] == "nav" and f.attrs["planner"] == "ompl-rrtstar"
        query = f["queries/0000"]
        assert query.attrs["success"] and query.attrs["seed"] == 4
        assert query.attrs["time_to_first_solution"] <= query.attrs["planning_time"]
        assert read_summary(f)["success_rate"][0] == 1.0


def test_nav_failed_query_exits_1_and_is_written(wall):
    tmp, map_path = wall
    queries = tmp / "queries.csv"
    queries.write_text("start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                       "1,1,0,0,5,1,0,0\n1,1,0,0,3,1,0,0\n")
    out = tmp / "nav_failed.h5"
    result = CliRunner().invoke(cli, ["baseline", "nav", str(map_path), "--queries", str(queries),
                                      "--time-budget", "0.2", "-o", str(out)])
    assert result.exit_code == 1
    assert "goal in collision" in result.stderr
    with h5py.File(out, "r") as f:
        assert f["queries/0000"].attrs["success"] and not f["queries/0001"].attrs["success"]


@pytest.mark.parametrize("args", [["--start", "1", "1"], ["--start", "1", "1", "--goal", "5", "1", "--planner", "sst"],
                                  ["--start", "1", "1", "--goal", "5", "1", "--time-budget", "0"]])
def test_nav_bad_input_exits_2_without_output(wall, args):
    tmp, map_path = wall
    out = tmp / "never.h5"
    result = CliRunner().invoke(cli, ["baseline", "nav", str(map_path), *args, "-o", str(out)])
    assert result.exit_code == 2
    assert not out.exists()


@pytest.fixture(scope="module")
def box_files(tmp_path_factory, box):
    """(directory for outputs, the box scene's map and steps.h5 of its three configurations)."""
    return tmp_path_factory.mktemp("baselinestep"), box.map_path, box.steps_file()


def test_step_writes_motion_read_by_the_step_reader(box_files):
    tmp, map_path, steps_path = box_files
    out = tmp / "motion_ompl.h5"
    result = CliRunner().invoke(cli, ["baseline", "step", str(map_path), str(steps_path), "--steps", "0",
                                      "--space", "tangent", "-o", str(out)])
    assert result.exit_code == 0, result.output + str(result.exception)
    (record,) = read_motion(out)
    assert record["success"] and record["planner"] == "ompl-rrtconnect-tangent"
    assert record["waypoints"].shape[1] == 18 and record["dense"]["foot_slip"] <= 1e-3
    with h5py.File(out, "r") as f:
        assert f.attrs["planner"] == "ompl-rrtconnect-tangent"
        assert read_summary(f)["steps_succeeded"][0] == 1


def test_step_out_of_time_exits_1(box_files):
    tmp, map_path, steps_path = box_files
    out = tmp / "motion_timeout.h5"
    result = CliRunner().invoke(cli, ["baseline", "step", str(map_path), str(steps_path), "--steps", "1",
                                      "--time-budget", "1e-9", "-o", str(out)])
    assert result.exit_code == 1
    (record,) = read_motion(out)
    assert not record["success"] and "budget" in record["reason"]


def test_step_bad_range_exits_2(box_files):
    tmp, map_path, steps_path = box_files
    result = CliRunner().invoke(cli, ["baseline", "step", str(map_path), str(steps_path), "--steps", "5:9",
                                      "-o", str(tmp / "never.h5")])
    assert result.exit_code == 2 and "--steps" in result.stderr
