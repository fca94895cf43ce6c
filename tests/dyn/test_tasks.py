"""The checked inputs of `legplan dyn plan`: task fields, tasks files, placement on the map, costs files."""

from dataclasses import replace

from types import SimpleNamespace

import numpy as np
import pytest

from legplan.dyn.problem import PAPER, DynParams, DynTask
from legplan.dyn.settings import dyn_params
from legplan.dyn.tasks import centroidal_model, check_placements, command_line_task, placement_problem, read_tasks
from legplan.dyn.terrain import TerrainModel
from legplan.errors import LegplanError, SpecError
from legplan.robots import load_robot
from legplan.terrain import Grid2D, terrain_from_heightmap

HEADER = "start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw"


@pytest.fixture(scope="module")
def pillar():
    """3 x 2 m flat ground with a 0.2 x 0.2 m pillar, 1 m high, centred at (1.0, 0.5)."""
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 151))
    x, y = grid.centres()
    height = np.where((np.abs(x - 1.0) < 0.1) & (np.abs(y - 0.5) < 0.1), 1.0, 0.0)
    return TerrainModel(terrain_from_heightmap(height, grid, name="pillar"))


def test_command_line_task_uses_the_planner_defaults():
    task = command_line_task((0.0, 0.1, 0.2), (1.0, 0.0, 0.0), None, None, None)
    assert task == DynTask((0.0, 0.1, 0.2), (1.0, 0.0, 0.0))
    assert command_line_task((0, 0, 0), (1, 0, 0), "walk", 3, 4.0) == DynTask((0, 0, 0), (1, 0, 0), "walk", 3, 4.0)


@pytest.mark.parametrize("gait, strides, duration, start, message", [
    ("run", None, None, (0, 0, 0), "field 'gait' must be one of walk, trot, got 'run'"),
    (None, 0, None, (0, 0, 0), "field 'strides' must be a whole number >= 1, got 0"),
    (None, None, 0.0, (0, 0, 0), "field 'duration' out of range: 0.0"),
    (None, None, float("nan"), (0, 0, 0), "field 'duration' must be a finite number, got nan"),
    (None, None, None, (float("inf"), 0, 0), "field 'start_x' must be a finite number, got inf"),
])
def test_command_line_task_rules(gait, strides, duration, start, message):
    with pytest.raises(SpecError, match="^command line: ") as error:
        command_line_task(start, (1.0, 0.0, 0.0), gait, strides, duration)
    assert message in str(error.value)


def test_csv_and_yaml_tasks_with_defaults(tmp_path):
    csv = tmp_path / "tasks.csv"
    csv.write_text(f"# two tasks\n{HEADER},gait,duration\n0,0,0,1,0,0,,\n0,0,0.1,1,0.2,0,walk,3.5\n")
    tasks = read_tasks(csv, gait="trot", strides=3)
    assert tasks == [DynTask((0, 0, 0), (1, 0, 0), "trot", 3, 2.4), DynTask((0, 0, 0.1), (1, 0.2, 0), "walk", 3, 3.5)]
    yaml = tmp_path / "tasks.yaml"
    yaml.write_text("tasks:\n  - {start_x: 0, start_y: 0, start_yaw: 0, goal_x: 1, goal_y: 0, goal_yaw: 0, strides: 2}\n")
    assert read_tasks(yaml) == [DynTask((0, 0, 0), (1, 0, 0), "trot", 2, 2.4)]


@pytest.mark.parametrize("text, message", [
    (f"{HEADER}\n0,0,0,1,0,0\n0,0,0,1,0,abc\n", "row 1: field 'goal_yaw' must be a finite number, got 'abc'"),
    (f"{HEADER},duration\n0,0,0,1,0,0,-2\n", "row 0: field 'duration' out of range: -2.0"),
    (f"{HEADER},speed\n0,0,0,1,0,0,3\n", "row 0: field 'speed' is unknown"),
    (f"{HEADER}\n0,0,0,1,0\n", "row 0: has 5 fields, the header has 6"),
    (f"{HEADER}\n0,0,nan,1,0,0\n", "row 0: field 'start_yaw' must be a finite number, got nan"),
    ("start_x,start_y,start_yaw,goal_x,goal_y\n0,0,0,1,0\n", "row 0: field 'goal_yaw' is missing"),
    (f"{HEADER},start_x\n0,0,0,1,0,0,0\n", "duplicate column 'start_x'"),
    (f"{HEADER}\n", "no tasks"),
])
def test_bad_csv_rows_name_the_row_and_field(tmp_path, text, message):
    path = tmp_path / "tasks.csv"
    path.write_text(text)
    with pytest.raises(SpecError, match=f"^{path}: ") as error:
        read_tasks(path)
    assert message in str(error.value)


@pytest.mark.parametrize("name, content, message", [
    ("tasks.yaml", "tasks: [1, 2]\n", "row 0: must be a mapping"),
    ("tasks.yaml", "jobs: []\n", "field 'jobs' is unknown"),
    ("tasks.yaml", "tasks: [{start_x: 0}\n", "invalid YAML"),
    ("tasks.txt", "", "unknown tasks file format '.txt'"),
    ("tasks.csv", b"\xff\xfe\x00garbage", "not UTF-8 text"),
])
def test_bad_tasks_files(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(SpecError, match=message):
        read_tasks(path)


def test_placement_off_the_map_and_in_a_wall(anymal, pillar):
    assert placement_problem((0.0, 0.0, 0.0), anymal, pillar) is None
    assert "puts the base at (2.000, 0.000) off" in placement_problem((2.0, 0.0, 0.0), anymal, pillar)
    assert "puts the foot lf" in placement_problem((1.3, 0.0, 0.0), anymal, pillar)  # base on, lf 4 cm off
    wall = placement_problem((1.0, 0.5, 0.0), anymal, pillar)
    assert "in a wall" in wall and "the base at 1.000 m" in wall
    assert "in a wall" in placement_problem((0.66, 0.31, 0.0), anymal, pillar)  # foot lf in the pillar
    tasks = [DynTask((0, 0, 0), (0.5, 0, 0)), DynTask((0, 0, 0), (1.0, 0.5, 0.0))]
    with pytest.raises(SpecError, match=r"^tasks.csv: row 1: field 'goal' \(1, 0.5, 0\) is in a wall of the map m.h5"):
        check_placements(tasks, anymal, pillar, "tasks.csv", "m.h5")


def test_leg_clearance_needs_legs_the_planner_can_place(tmp_path, monkeypatch):
    """The planner's model carries the robot's leg chains (`ChainLegs`); a robot whose legs are no
    chains it can follow is refused with one line naming the costs source and the field when leg
    clearance is asked for; without leg clearance it plans as before."""
    from legplan.dyn.legs import ChainLegs

    robot = load_robot("anymal")
    assert centroidal_model(robot, replace(PAPER, leg_clearance=0.05)).leg_kinematics is robot.centroidal.leg_kinematics
    other = SimpleNamespace(**{k: getattr(robot, k) for k in ("model", "legs", "n_legs", "spheres", "q_nominal", "lower", "upper", "yaml_path",
                                                                   "foot_jacobians", "mass")},
                            centroidal=replace(robot.centroidal, leg_kinematics=None))  # no closed form
    assert isinstance(centroidal_model(other, replace(PAPER, leg_clearance=0.05)).leg_kinematics, ChainLegs)
    robot = other
    monkeypatch.setattr(ChainLegs, "of_robot", classmethod(lambda cls, r: None))
    assert centroidal_model(robot, replace(PAPER, leg_clearance=None), "c.yaml").leg_kinematics is None
    with pytest.raises(LegplanError, match=r"^c.yaml: field 'leg_clearance': .*robot.yaml's legs are not"):
        centroidal_model(robot, replace(PAPER, leg_clearance=0.05), "c.yaml")


def test_costs_presets_and_files(tmp_path):
    assert dyn_params("paper") == PAPER and dyn_params("none") == DynParams()
    good = tmp_path / "costs.yaml"
    good.write_text("base_angular_velocity: 2.0\nforce_rate: 0.5\nswing_height_min: 0.04\nbase_clearance: null\n")
    params = dyn_params(str(good))
    assert params.costs.base_angular_velocity == 2.0 and params.costs.force_rate == 0.5 and params.costs.force == 0.0
    assert params.swing_height_min == 0.04 and params.base_clearance is None
    for text, message in (("force: -1\n", "field 'force' must be >= 0"), ("stair_edge_sigma: 0\n", "field 'stair_edge_sigma' must be > 0"),
                          ("speed: 1\n", "field 'speed' is unknown"), ("force: .nan\n", "field 'force' must be a finite number")):
        good.write_text(text)
        with pytest.raises(SpecError, match=f"^{good}: {message}"):
            dyn_params(str(good))
    good.write_text("preset: paper\nleg_clearance: 0.06\nforce_rate: 0.5\nbase_clearance: null\n")
    params = dyn_params(str(good))  # the preset's fields unless given; null switches a constraint off
    assert params == replace(PAPER, costs=replace(PAPER.costs, force_rate=0.5), leg_clearance=0.06, base_clearance=None)
    for text, message in (("preset: towr\n", "field 'preset' must be one of paper, none"),
                          ("preset: paper\nleg_clearance: -0.01\n", "field 'leg_clearance' must be >= 0")):
        good.write_text(text)
        with pytest.raises(SpecError, match=f"^{good}: {message}"):
            dyn_params(str(good))
    with pytest.raises(LegplanError, match="--costs: 'missing.yaml' is neither a preset"):
        dyn_params("missing.yaml")
