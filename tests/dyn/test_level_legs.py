"""Leg clearance on a level map: the rows are left out while a plan's legs stay off the ground, and
a "range of motion" round adds them, with their `DynParams.leg_clearance` margin, when a plan's leg
spheres touch the ground (a crouched robot's shanks), so the plan passes the independent check's
`leg_penetration` as it does on any other map."""

from pathlib import Path

import pytest

from legplan.dyn.planner import plan
from legplan.dyn.problem import DynTask, legs_touch_level_ground
from legplan.dyn.settings import dyn_params
from legplan.dyn.tasks import centroidal_model
from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.terrain import build_map
from legplan.validate.trajectory import check_trajectory

FLAT = Path(__file__).parents[2] / "maps" / "flat.yaml"


@pytest.fixture(scope="module")
def flat_map():
    return build_map(FLAT)


def _planned(name: str, task: DynTask, terrain_map):
    """`name` plans `task` on the map with the paper's costs, as `dyn plan --costs paper` does."""
    robot = load_robot(name)
    params = dyn_params("paper")
    model = centroidal_model(robot, params, "paper")
    result = plan(task, model, TerrainModel(terrain_map), params)
    check = check_trajectory(result.samples, model, terrain_map, robot, node_times=result.problem.form.knots)
    return params, result, check


def test_a_crouched_robot_on_flat_ground_plans_with_its_shanks_held_clear(flat_map):
    """jueying_mini_dyn stands crouched: its calf spheres reach the ground. The plan's stages before the
    rows were added (none on a level map) ended with them in the ground; the round that
    follows holds the rows, and the plan passes the check, `leg_penetration` included."""
    params, result, check = _planned("jueying_mini_dyn", DynTask((-0.386, -0.073, 0.052), (0.0, 0.0, 0.0),
                                                                 "trot", 4, 2.4), flat_map)
    assert result.success, result.reason
    added = next(i for i, s in enumerate(result.stages) if s.problem.level_legs)
    before = result.stages[added - 1]
    assert before.success and not any(k.name == "leg_clearance" for k in before.problem.constraints)
    assert legs_touch_level_ground(before.problem, params, before.result.values)
    assert result.stages[added].name == "range of motion"
    assert result.problem.level_legs and any(k.name == "leg_clearance" for k in result.problem.constraints)
    assert check.ok, check.failures()
    assert check.worst["leg_penetration"] <= -params.leg_clearance + 2 * params.solver.violation_tolerance


def test_an_upright_robot_on_flat_ground_keeps_no_leg_rows(flat_map):
    """ANYmal's legs stay off flat ground (its paper-cost trot within the margin): no round is added
    for them and no rows are built."""
    params, result, check = _planned("anymal", DynTask((0.0, 0.0, 0.0), (0.8, 0.1, 0.2), "trot", 4, 2.4), flat_map)
    assert result.success and check.ok, result.reason
    assert not result.problem.level_legs
    assert not any(k.name == "leg_clearance" for k in result.problem.constraints)
    assert not legs_touch_level_ground(result.problem, params, result.solve.values)
