"""legplan.sim and `legplan dyn simulate`: the MuJoCo model from the robot folder, standing under the
whole-body controller, a planned walk reaching its goal, a planted fall, the artefact, bad input."""

import h5py
import mujoco
import numpy as np
import pinocchio as pin
import pytest
from click.testing import CliRunner
from stance import standing

from legplan.cli.main import cli
from legplan.robots import load_robot
from legplan.sim.model import build_model
from legplan.sim.run import SimParams, simulate
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_model_has_the_urdf_masses_inertias_joints_and_limits(robot, flat):
    sim = build_model(robot, flat[0], 0.5)
    m, pm = sim.model, robot.model
    assert m.nq == pm.nq and m.nv == pm.nv and m.nu == robot.n_joints
    for jid in range(1, pm.njoints):
        name, inertia = pm.names[jid], pm.inertias[jid]
        if jid == 1:   # the free-flyer: MuJoCo's root body
            body = m.body(1)
        else:
            joint = m.joint(name)
            body = m.body(int(m.jnt_bodyid[joint.id]))
            q = pm.idx_qs[jid]
            assert m.jnt_range[joint.id] == pytest.approx([pm.lowerPositionLimit[q], pm.upperPositionLimit[q]])
        assert float(m.body_mass[body.id]) == pytest.approx(inertia.mass)
        # principal moments about the body's CoM equal those of the URDF's inertia tensor
        assert np.sort(m.body_inertia[body.id]) == pytest.approx(np.linalg.eigvalsh(inertia.inertia), rel=1e-6)
    assert float(m.body_subtreemass[1]) == pytest.approx(robot.mass)
    assert m.actuator_ctrlrange == pytest.approx(np.column_stack([-sim.effort, sim.effort]))
    assert sim.effort == pytest.approx(40.0)
    assert len(sim.foot_geoms) == 4 and len(sim.body_geoms) == len(robot.spheres) - 4
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    geomgroup = np.array([1, 0, 0, 0, 0, 0], np.uint8)
    for x, top in ((0.0, 0.0), (1.5, 0.1)):
        distance = mujoco.mj_ray(m, data, np.array([x, 0.5, 1.0]), np.array([0.0, 0.0, -1.0]), geomgroup, 1, -1,
                                 np.zeros(1, np.int32))
        assert 1.0 - distance == pytest.approx(top, abs=1e-6)


def test_standing_still_keeps_the_base_within_1_cm(robot, flat):
    result = simulate(standing(robot), robot, flat[0], SimParams(settle=0.0))
    assert result.success and not result.fell and result.qp_failures == 0
    assert result.max_position_error < 0.01 and result.max_orientation_error < 0.01
    weight = result.series["foot_forces"][-1][:, 2].sum()
    assert weight == pytest.approx(robot.mass * 9.81, rel=0.02)
    assert result.unplanned_contacts == []


def test_zero_torques_is_a_fall(robot, flat):
    result = simulate(standing(robot), robot, flat[0], SimParams(zero_torque=True))
    assert not result.success and result.fell and result.reason.startswith("fell at")
    assert result.fall_time < 1.0
    # without the height threshold the collapse is still a fall: the trunk lands on the terrain
    result = simulate(standing(robot), robot, flat[0], SimParams(zero_torque=True, fall_height=0.0))
    assert not result.success and result.reason.endswith("trunk on the terrain")
    assert any("base_link" in name for name in result.unplanned_contacts)


def test_a_failed_execution_is_recorded_and_exits_1(flat, trot, tmp_path):
    out = tmp_path / "sim.h5"
    result = invoke("dyn", "simulate", trot, flat[1], "--friction", "0.1", "-o", out)   # the feet slip
    assert result.exit_code == 1, result.output
    with h5py.File(out) as handle:
        task = handle["tasks/0000"]
        assert not task.attrs["success"] and task.attrs["reason"].startswith("fell at")
        assert task["series/t"][-1] == pytest.approx(task.attrs["fall_time"])


def test_a_planned_flat_trot_reaches_its_goal_from_the_cli(flat, trot, tmp_path):
    out = tmp_path / "sim.h5"
    result = invoke("dyn", "simulate", trot, flat[1], "-o", out)
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out) as handle:
        assert handle.attrs["legplan_kind"] == "sim"
        task = handle["tasks/0000"]
        assert task.attrs["success"] and task.attrs["goal_error"] < 0.1
        assert task.attrs["rms_position_error"] < 0.02 and task.attrs["peak_torque"] <= 40.0 + 1e-9
        assert not task.attrs["fell"] and task.attrs["unplanned_contacts"] == ""
        assert task["series/position_error"].attrs["units"] == "m"
        quat = task["series/base_quat"][-1]
        assert abs(pin.log3(pin.Quaternion(*quat[[3, 0, 1, 2]]).matrix())).max() < 0.2


@pytest.mark.parametrize("case", ["not_traj", "missing", "off_map"])
def test_bad_input_exits_2_and_writes_nothing(flat, trot, tmp_path, case):
    out = tmp_path / "sim.h5"
    if case == "not_traj":
        args = (flat[1], flat[1])
    elif case == "missing":
        args = (tmp_path / "nope.h5", flat[1])
    else:
        small = Grid2D(origin=(-0.6, -0.4), resolution=0.02, shape=(41, 61))
        save_map(terrain_from_heightmap(np.zeros(small.shape), small, name="small"), tmp_path / "small.h5")
        args = (trot, tmp_path / "small.h5")
    result = invoke("dyn", "simulate", *args, "-o", out)
    assert result.exit_code == 2, result.output
    assert not out.exists()


def test_feet_given_as_link_and_offset_sit_on_their_link(robot, flat, tmp_path):
    """robot.yaml feet as `{link: shank, offset}` (frames added to the model, not URDF links): the
    foot spheres go on the shank bodies at the same places as the URDF foot links'."""
    import shutil

    import yaml

    folder = tmp_path / "anymal_link_feet"
    shutil.copytree(robot.yaml_path.parent, folder)
    spec = yaml.safe_load((folder / "robot.yaml").read_text())
    model = robot.model
    for leg in spec["legs"]:
        foot = model.frames[model.getFrameId(leg.pop("foot_frame"))]
        shank = model.frames[foot.parentFrame]
        while shank.type != pin.FrameType.BODY:       # up through the fixed joint to the shank link
            shank = model.frames[shank.parentFrame]
        leg["foot"] = {"link": shank.name, "offset": shank.placement.actInv(foot.placement.translation).tolist()}
    for sphere in spec["collision_spheres"]:
        sphere["link"] = sphere["link"].replace("foot_{leg}", "{leg}_foot")
    (folder / "robot.yaml").write_text(yaml.safe_dump(spec))
    linked = load_robot(folder)
    assert linked.model.frames[linked.legs[0].foot_frame_id].type == pin.FrameType.OP_FRAME
    positions = []
    for each in (robot, linked):
        sim = build_model(each, flat[0], 0.5)
        data = mujoco.MjData(sim.model)
        mujoco.mj_forward(sim.model, data)
        positions.append(data.geom_xpos[sim.foot_geoms].copy())
    np.testing.assert_allclose(positions[1], positions[0], atol=1e-12)
    np.testing.assert_allclose(positions[1][:, :2], robot.foot_positions(pin.neutral(robot.model))[0][:, :2],
                               atol=1e-9)


def test_a_robot_given_by_path_is_simulated_from_its_folder(flat, tmp_path):
    """A robot folder that is on no search path (one `robot init` just drafted, say): `dyn plan`
    records its robot.yaml's path and `dyn simulate` loads that robot, not one found by name."""
    import shutil

    folder = tmp_path / "my_quadruped"
    shutil.copytree(load_robot("anymal").yaml_path.parent, folder)
    spec = folder / "robot.yaml"
    spec.write_text(spec.read_text().replace("name: anymal\n", "name: my_quadruped\n"))
    traj, out = tmp_path / "traj.h5", tmp_path / "sim.h5"
    planned = CliRunner().invoke(cli, ["dyn", "plan", str(flat[1]), "--robot", str(folder), "--start", "0", "0", "0",
                                       "--goal", "0.5", "0", "0", "--strides", "2", "--duration", "1.6", "-o",
                                       str(traj), "-q"])
    assert planned.exit_code == 0, planned.output
    with h5py.File(traj) as handle:
        assert handle.attrs["robot"] == str(spec.resolve())
    result = CliRunner().invoke(cli, ["dyn", "simulate", str(traj), str(flat[1]), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    with h5py.File(out) as handle:
        assert handle["tasks/0000"].attrs["success"]


def test_the_same_plan_simulated_twice_gives_the_same_run(flat, trot, tmp_path):
    """MuJoCo is deterministic and the controller's QP solution is rounded below its effect and above
    ProxQP's last bits (`legplan.sim.controller.QP_RESOLUTION_DECIMALS`), so two runs of one plan
    record the same series bit for bit."""
    outs = [tmp_path / f"sim{i}.h5" for i in range(2)]
    for out in outs:
        assert invoke("dyn", "simulate", trot, flat[1], "-o", out).exit_code == 0
    with h5py.File(outs[0]) as a, h5py.File(outs[1]) as b:
        series_a, series_b = a["tasks/0000/series"], b["tasks/0000/series"]
        assert sorted(series_a) == sorted(series_b) and len(series_a) > 5
        for name in series_a:
            assert np.array_equal(series_a[name][()], series_b[name][()]), name
