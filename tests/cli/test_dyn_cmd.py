"""`legplan dyn plan|show` end to end on small flat maps: the traj artefact, a tasks file with an
infeasible task, bad input (exit 2, nothing written), figures, and report / compare / inspect."""

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.artefacts import read_summary, write_artefact, write_dataset
from legplan.cli.main import cli
from legplan.shipped import list_shipped_initializers
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap
from jobs_support import assert_forked_from_command
from pictures import drawn, pixels, share

TROT = ["--gait", "walk", "--strides", "2", "--duration", "3.0", "--start", "0", "0", "0", "--goal", "0.6", "0", "0"]
"""A 3 s walk (cheaper to plan than a flying trot, whose support pairs get short base polynomials)."""


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """A flat 3 x 2 m map with a 1 m pillar at (1.0, 0.5), and a 3 s walk planned on it."""
    tmp = tmp_path_factory.mktemp("dyncli")
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    x, y = grid.centres()
    height = np.where((np.abs(x - 1.0) < 0.1) & (np.abs(y - 0.5) < 0.1), 1.0, 0.0)
    map_path = tmp / "map.h5"
    save_map(terrain_from_heightmap(height, grid, name="pillar"), map_path)
    out = tmp / "traj.h5"
    result = invoke("dyn", "plan", map_path, *TROT, "-o", out, "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    return tmp, map_path, out


def test_plan_writes_the_traj_artefact(planned):
    _, map_path, out = planned
    with h5py.File(out, "r") as f:
        assert f.attrs["legplan_kind"] == "traj" and f.attrs["robot"] == "anymal"
        assert f.attrs["legs"] == "lf,rf,lh,rh"
        params = json.loads(f.attrs["params"])
        assert params["costs"] == "none" and params["gait"] == "walk" and params["dyn"]["dt"] == 0.1
        assert json.loads(f.attrs["inputs"])[0]["kind"] == "map"
        task = f["tasks/0000"]
        assert task.attrs["success"] and "max violation" in task.attrs["reason"]
        assert task.attrs["iterations"] >= 1 and task.attrs["max_violation"] <= 1e-3
        assert task.attrs["paper_variables"] == 640 and 600 < task.attrs["variables"] <= 700
        parts = sum(task[f"timings/{name}"][()] for name in ("evaluate", "assemble", "factorize", "solve"))
        assert task["timings/total"][()] == task.attrs["solve_seconds"] >= parts > 0   # the split is part of the total
        assert task["timings/total"].attrs["units"] == "s"
        assert {"evaluate", "assemble", "factorize", "solve"} <= set(task["timings"])
        assert "dynamics" in task["violations"] and task["violations/dynamics"][()] <= 1e-3
        for name, units in (("t", "s"), ("base_pos", "m"), ("base_ang_vel", "rad/s"), ("forces", "N")):
            assert task[f"samples/{name}"].attrs["units"] == units
        t = task["samples/t"][()]
        assert t[0] == 0 and t[-1] == pytest.approx(3.0) and np.allclose(np.diff(t)[:-1], 0.01)
        assert task["samples/forces"].shape == (len(t), 4, 3) and task["samples/contact"].dtype == bool
        assert task["samples/base_pos"][-1, 0] == pytest.approx(0.6)
        assert task["phases/durations"][()].sum() == pytest.approx(3.0) and task["phases/stance"].shape[1] == 4
        for block in ("base_lin", "base_ang", "feet", "forces"):
            value, fixed = task[f"nodes/{block}/value"][()], task[f"nodes/{block}/fixed"][()]
            assert value.shape == fixed.shape and fixed.dtype == bool and fixed.any()
        free = sum(int((~task[f"nodes/{b}/fixed"][()]).sum()) for b in ("base_lin", "base_ang", "feet", "forces"))
        assert free == task.attrs["variables"]
        assert set(task["nodes/feet/leg"][()]) == {0, 1, 2, 3}
        check = task["check"]
        assert check["penetration_height"][()] <= 5e-3 and check["penetration_height"].attrs["units"] == "m"
        assert "tolerance" in check["stance_slip"].attrs and "passed" in check.attrs
        assert len(task["history/violation"]) == task.attrs["outer_iterations"]
        summary = read_summary(f)
    assert summary["tasks"][0] == 1 and summary["succeeded"][0] == 1
    assert summary["median_solve_time"][1] == "s" and summary["median_paper_variables"][0] == 640
    assert summary["check_penetration_height"] == (check_value(out, "penetration_height"), "m")
    assert summary["check_base_height"][0] > 0.3  # a minimum: the base stays above the ground


def test_plan_with_optimized_phase_durations(planned, tmp_path):
    """--optimize-phases: recorded in the params, 2S = 16 more variables than the fixed-timing run
    (8 footsteps), phase durations of the plan's own summing to T, and the check passed."""
    _, map_path, fixed = planned
    out = tmp_path / "phases.h5"
    result = invoke("dyn", "plan", map_path, *TROT, "--optimize-phases", "-o", out, "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(fixed, "r") as f:
        fixed_variables = int(f["tasks/0000"].attrs["variables"])
        fixed_durations = f["tasks/0000/phases/durations"][()]
        assert json.loads(f.attrs["params"])["dyn"]["optimize_phases"] is False
    with h5py.File(out, "r") as f:
        assert json.loads(f.attrs["params"])["dyn"]["optimize_phases"] is True
        task = f["tasks/0000"]
        assert task.attrs["success"]
        assert task.attrs["variables"] == fixed_variables + 16
        durations = task["phases/durations"][()]
        assert durations.sum() == pytest.approx(3.0) and durations.min() > 0
        assert durations.shape != fixed_durations.shape or not np.allclose(durations, fixed_durations)
        assert task["check"].attrs["passed"]


def check_value(path, metric):
    with h5py.File(path, "r") as f:
        return float(f[f"tasks/0000/check/{metric}"][()])


def test_tasks_file_records_an_infeasible_task_as_failed(planned, tmp_path):
    _, map_path, _ = planned
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw,gait,strides,duration\n"
                     "0,0,0,1.5,0,0,walk,1,0.8\n")  # 1.5 m in 0.8 s with one stride: beyond the range of motion
    out = tmp_path / "tasks.h5"
    result = invoke("dyn", "plan", map_path, "--tasks", tasks, "-o", out)
    assert result.exit_code == 1, result.output + str(result.exception)
    assert "task 0: failed: " in result.stderr and "stalled" in result.stderr
    with h5py.File(out, "r") as f:
        task = f["tasks/0000"]
        assert not task.attrs["success"] and "stalled" in task.attrs["reason"]
        assert task.attrs["gait"] == "walk" and task.attrs["duration"] == 0.8
        assert task.attrs["max_violation"] > 1e-3 and "samples" in task and "check" in task
        summary = read_summary(f)
    assert summary["succeeded"][0] == 0 and np.isnan(summary["peak_force"][0])
    assert not (tmp_path / "tasks.h5.work").exists()


def test_tasks_with_two_jobs_are_planned_by_workers_forked_from_the_command(planned, tmp_path):
    """`dyn plan --tasks` with --jobs 2: the workers are forked from the command with the context it
    built while checking its inputs, and write the --jobs 1 traj.h5 (a failed task's record too)."""
    _, map_path, _ = planned
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw,gait,strides,duration\n"
                     "0,0,0,0.6,0,0,walk,2,3.0\n0,0,0,1.5,0,0,walk,1,0.8\n0,0,0,0.3,0,0,walk,2,3.0\n")
    argv = ["dyn", "plan", map_path, "--tasks", tasks]
    result = invoke(*argv, "-o", tmp_path / "one.h5", "-q")
    assert result.exit_code == 1, result.output + str(result.exception)
    assert_forked_from_command(argv, tmp_path / "two.h5", tmp_path / "one.h5", exit_code=1)


def test_a_plan_that_fails_its_check_exits_1(planned, tmp_path):
    """A converged plan whose independent check fails is a failed task: exit 1, the reason names the
    check's failed metrics. A trot planned with the between-knot band as wide as m·g and TOWR's
    evenly spaced knots converges with dynamics the check refuses between the knots."""
    _, map_path, _ = planned
    out = tmp_path / "trot.h5"
    trot = ["--gait", "trot", "--strides", "4", "--duration", "2.4", "--start", "0", "0", "0", "--goal", "1", "0", "0",
            "--param", "dynamics_band=1", "--param", "unloaded_polynomials=null"]
    result = invoke("dyn", "plan", map_path, *trot, "-o", out)
    assert result.exit_code == 1, result.output + str(result.exception)
    assert "task 0: failed: check: newton_euler" in result.stderr and "0/1 tasks planned" in result.stderr + result.output
    with h5py.File(out, "r") as f:
        task = f["tasks/0000"]
        assert not task.attrs["success"] and task.attrs["solved"]
        assert task.attrs["reason"].startswith("check: ") and not task["check"].attrs["passed"]


@pytest.mark.parametrize("args, message", [
    (["--gait", "gallop"], "command line: field 'gait' must be one of walk, trot, got 'gallop'"),
    (["--duration", "-1"], "Invalid value for '--duration': -1.0 is not in the range 0.01<=x<=3600.0"),
    (["--strides", "0"], "Invalid value for '--strides': 0 is not in the range 1<=x<=10000"),
    (["--start", "nan", "0", "0"], "Invalid value for '--start': 'nan' is not a finite number"),
    (["--goal", "1", "inf", "0"], "Invalid value for '--goal': 'inf' is not a finite number"),
    (["--goal", "3", "0", "0"], "command line: field 'goal' (3, 0, 0) puts the base at (3.000, 0.000) off the map"),
    (["--start", "1", "0.5", "0"], "command line: field 'start' (1, 0.5, 0) is in a wall of the map"),
    (["--robot", "scarab2"], "robots/scarab2/robot.yaml: field 'centroidal' is missing"),
    (["--init", "learned"], "--init: unknown initializer 'learned' (known: heuristic, an INIT.h5, or a shipped one: "
                            + ", ".join(list_shipped_initializers()) + ")"),
    (["--costs", "cheap"], "--costs: 'cheap' is neither a preset (paper, none) nor a file"),
    (["--costs", "COSTS"], "costs.yaml: field 'speed' is unknown"),
    (["--tasks", "TASKS"], "dyn plan: give either --tasks or --start/--goal, not both"),
])
def test_bad_input_exits_2_with_one_line_and_no_output(planned, tmp_path, args, message):
    _, map_path, _ = planned
    (tmp_path / "costs.yaml").write_text("force: 1.0\nspeed: 2\n")
    args = [str(tmp_path / "costs.yaml") if a == "COSTS" else str(tmp_path / "t.csv") if a == "TASKS" else a
            for a in args]
    options = list(TROT)
    for name in ("--start", "--goal", "--gait", "--duration", "--strides"):
        if name in args and name in options:  # the test's value replaces the default trot's
            k = options.index(name)
            del options[k:k + (4 if name in ("--start", "--goal") else 2)]
    out = tmp_path / "bad.h5"
    result = invoke("dyn", "plan", map_path, *options, *args, "-o", out)
    assert result.exit_code == 2, result.output + str(result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr
    assert not out.exists() and not (tmp_path / "bad.h5.work").exists()


@pytest.mark.parametrize("text, message", [
    ("preset: towr\n", "field 'preset' must be one of paper, none, got 'towr'"),
    ("preset: [paper]\n", "field 'preset' must be one of paper, none, got ['paper']"),
    ("preset: paper\nleg_clearance: .nan\n", "field 'leg_clearance' must be a finite number"),
    ("leg_clearance: -0.1\n", "field 'leg_clearance' must be >= 0"),
    ("leg_clearance: high\n", "field 'leg_clearance'"),
])
def test_bad_costs_file_presets_and_leg_clearance_exit_2(planned, tmp_path, text, message):
    """The costs file's `preset` and `leg_clearance` by input class: one line naming the file and
    the field, exit 2, no artefact."""
    _, map_path, _ = planned
    costs = tmp_path / "costs.yaml"
    costs.write_text(text)
    out = tmp_path / "bad.h5"
    result = invoke("dyn", "plan", map_path, *TROT, "--costs", costs, "-o", out)
    assert result.exit_code == 2, result.output + str(result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{costs}: {message}" in lines[0], result.stderr
    assert not out.exists() and not (tmp_path / "bad.h5.work").exists()


def test_bad_maps_and_tasks_files(planned, tmp_path):
    _, map_path, _ = planned
    no_height = tmp_path / "no_height.h5"
    with write_artefact(no_height, "map") as f:
        write_dataset(f, "terrain/sdf", np.zeros((2, 2, 2)), units="m")
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw\n0,0,0,1,0,0\n0,0,0,1,0,0,5\n")
    for argv, message in (([no_height, *TROT], "no_height.h5: missing dataset '/terrain/height'"),
                          ([map_path, "--tasks", tasks], "tasks.csv: row 1: has 7 fields, the header has 6")):
        out = tmp_path / "bad.h5"
        result = invoke("dyn", "plan", *argv, "-o", out)
        assert result.exit_code == 2 and message in result.stderr, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1 and not out.exists()


def test_show_draws_one_run_and_a_comparison(planned):
    tmp, _, out = planned
    for paths, png in (([out], tmp / "fig3.png"), ([out, out], tmp / "fig4.png")):
        result = invoke("dyn", "show", *paths, "-o", png)
        assert result.exit_code == 0, result.output + str(result.exception)
        image = pixels(png)
        assert drawn(image) > 0.03 and share(image, "tab:blue") > 1e-3 and share(image, "tab:orange") > 1e-3
        if png.name == "fig3.png":   # the optimization nodes, red dots on the samples
            assert share(image, "red") > 1e-4
    result = invoke("dyn", "show", out, "--task", "3", "-o", tmp / "none.png")
    assert result.exit_code == 2 and "--task 3: the artefact has 1 task(s)" in result.stderr


def test_report_compare_and_inspect_know_traj(planned):
    tmp, _, out = planned
    result = invoke("report", out, "-o", tmp / "report")
    assert result.exit_code == 0, result.output + str(result.exception)
    html = (tmp / "report" / "index.html").read_text()
    assert "00-traj-trajectory.png" in html and "00-traj-tasks.png" in html
    result = invoke("compare", out, out)
    assert result.exit_code == 0 and "item samples/forces (array)" in result.output
    result = invoke("inspect", out, "--full")
    assert result.exit_code == 0 and "traj artefact" in result.output
    assert "/tasks/0000/samples/forces: 301x4x3 float64 [N]" in result.output
