"""The joint torque limits a robot has (`legplan.robots.torque_limits`): robot.yaml's where given,
else the URDF's efforts, and the same limits in the planner's model, the simulator's motors and the
independent check."""

import shutil

import numpy as np
import pytest
import yaml

from legplan.robots import joint_efforts, load_robot, shipped_robots_dir, torque_limits


def _anymal_with(tmp_path, limits: dict | None):
    """A copy of the shipped anymal whose robot.yaml names `limits` (leg -> three N m), or none."""
    folder = tmp_path / "anymal"
    shutil.copytree(shipped_robots_dir() / "anymal", folder)
    spec = yaml.safe_load((folder / "robot.yaml").read_text())
    if limits is not None:
        spec["centroidal"]["torque_limits"] = limits
    (folder / "robot.yaml").write_text(yaml.safe_dump(spec))
    return load_robot(folder / "robot.yaml")


def test_a_robot_without_torque_limits_has_its_urdf_efforts(anymal):
    """The shipped anymal's robot.yaml names none: every leg's joints get the URDF's efforts."""
    assert anymal.centroidal.torque_limits is None
    limits = torque_limits(anymal)
    efforts = np.asarray(anymal.model.effortLimit, float)
    assert len(limits) == anymal.n_legs
    for leg, leg_limits in zip(anymal.legs, limits):
        np.testing.assert_array_equal(leg_limits, efforts[list(leg.joint_idx_v)])
    np.testing.assert_array_equal(joint_efforts(anymal), efforts[6:])


def test_written_torque_limits_rule_the_planner_and_the_simulator(tmp_path):
    """robot.yaml's own limits (different per leg and joint, below the URDF's 40 N m) are what the
    planner's model holds and what the simulator's motors give (× --effort-scale, after --effort);
    the check divides by them too (tests/validate/test_centroidal_check.py)."""
    from legplan.dyn.tasks import centroidal_model
    from legplan.sim.model import ModelOptions, joint_limits

    written = {"lf": [21.0, 22.0, 23.0], "rf": [24.0, 25.0, 26.0], "lh": [27.0, 28.0, 29.0], "rh": [30.0, 31.0, 32.0]}
    robot = _anymal_with(tmp_path, written)
    limits = torque_limits(robot)
    for leg, leg_limits in zip(robot.legs, limits):
        np.testing.assert_array_equal(leg_limits, written[leg.name])
    model = centroidal_model(robot)
    for a, b in zip(model.torque_limits, limits):
        np.testing.assert_array_equal(a, b)
    effort, _, _ = joint_limits(robot, ModelOptions())
    for leg in robot.legs:
        np.testing.assert_array_equal(effort[list(leg.joint_idx)], written[leg.name])
    scaled, _, _ = joint_limits(robot, ModelOptions(effort_scale=2.0, effort=(("haa_lf", 5.0),)))
    assert scaled[robot.joint_names.index("haa_lf")] == 10.0 and scaled[robot.joint_names.index("kfe_rh")] == 64.0


def test_the_planner_bounds_joint_torques_of_a_robot_without_torque_limits(anymal):
    """The planner's model of the shipped anymal keeps |Jᵀf| inside the URDF's efforts (its leg
    chains place the joints): the check would fail a plan that needs more."""
    from legplan.dyn.tasks import centroidal_model

    model = centroidal_model(anymal)
    assert model.leg_chains is not None
    for a, b in zip(model.torque_limits, torque_limits(anymal)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("limits", [{"lf": [41.0, 40.0, 40.0]}])
def test_torque_limits_above_the_urdf_stay_refused(tmp_path, limits):
    from legplan.errors import SpecError

    full = {leg: [40.0, 40.0, 40.0] for leg in ("lf", "rf", "lh", "rh")} | limits
    with pytest.raises(SpecError, match=r"centroidal\.torque_limits\.lf"):
        _anymal_with(tmp_path, full)


def test_robot_show_names_where_the_limits_come_from(anymal, tmp_path):
    """`robot show` prints the limits the robot has and their source: the URDF's efforts for the
    shipped anymal, robot.yaml's for a copy that names them."""
    import json

    from click.testing import CliRunner

    from legplan.cli.main import cli

    text = CliRunner().invoke(cli, ["robot", "show", "anymal"]).output
    assert "torque limits lf [N m, URDF efforts]: haa_lf 40, hfe_lf 40, kfe_lf 40" in text, text
    written = _anymal_with(tmp_path, {leg: [30.0, 31.0, 32.0] for leg in ("lf", "rf", "lh", "rh")})
    shown = json.loads(CliRunner().invoke(cli, ["robot", "show", str(written.yaml_path), "--json"]).output)
    assert shown["centroidal"]["torque_limits_from"] == "robot.yaml"
    assert shown["centroidal"]["torque_limits"]["rh"] == [30.0, 31.0, 32.0]


def test_robot_check_raises_no_scalar_force_warning_where_the_joints_bound_the_forces(anymal):
    """The shipped anymal's 1000 N max_normal_force is more than its 40 N m joints give at the
    stance, but the joints' limits bound the planned forces through the legs: no warning."""
    from legplan.robots.check import check_robot
    from legplan.robots.rigid_body import leg_forces

    assert anymal.centroidal.max_normal_force > leg_forces(anymal).force.min()
    assert not [f for f in check_robot(anymal) if f.subject == "centroidal.max_normal_force"]
