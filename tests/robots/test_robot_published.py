"""`robot init` -> `robot check` on published quadrupeds (example-robot-data, a test dependency):
ANYmal B and C, HyQ, Go1 and Solo12, URDFs and meshes as shipped, no edits, no options."""

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from legplan.robots import joint_efforts, load_robot, torque_limits
from legplan.robots.check import check_robot
from legplan.robots.draft import write_draft
from legplan.robots.rigid_body import GRAVITY

ROBOTS = {   # name: (URDF under robots/, leg names as the URDF writes them, a foot link)
    "anymal_b": ("anymal_b_simple_description/robots/anymal.urdf", ("LF", "RF", "LH", "RH"), "LF_FOOT"),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", ("LF", "RF", "LH", "RH"), "LF_FOOT"),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", ("lf", "rf", "lh", "rh"), "lf_foot"),
    "go1": ("go1_description/urdf/go1.urdf", ("FL", "FR", "RL", "RR"), "FL_foot"),
    "solo12": ("solo_description/robots/solo12.urdf", ("FL", "FR", "HL", "HR"), "FL_FOOT"),
}


@pytest.fixture(scope="module")
def drafted(published_robots, tmp_path_factory):
    """name -> (drafted robot.yaml, warnings), drafted once per module."""
    out = {}
    for name, (urdf, _, _) in ROBOTS.items():
        path, draft = write_draft(published_robots / urdf, tmp_path_factory.mktemp("robots") / name)
        out[name] = (path, draft.warnings)
    return out


def _independent_body(model, q):
    """Mass, CoM (world) and inertia about it (world) summed link by link (no ccrba)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    masses, coms, inertias = [], [], []
    for j in range(1, model.njoints):
        inertia, placement = model.inertias[j], data.oMi[j]
        masses.append(inertia.mass)
        coms.append(placement.act(inertia.lever))
        inertias.append(placement.rotation @ inertia.inertia @ placement.rotation.T)
    masses, coms = np.array(masses), np.array(coms)
    com = masses @ coms / masses.sum()
    total = sum(i + m * ((r - com) @ (r - com) * np.eye(3) - np.outer(r - com, r - com))
                for m, r, i in zip(masses, coms, inertias))
    return masses.sum(), com, total


@pytest.mark.parametrize("name", ROBOTS)
def test_published_quadruped_drafts_and_checks_clean(name, drafted, published_robots):
    path, warnings = drafted[name]
    robot = load_robot(path)                        # strict: the centroidal section agrees with the URDF
    findings = check_robot(robot)
    assert [str(f) for f in findings if f.severity == "error"] == []
    _, leg_names, foot_link = ROBOTS[name]
    assert tuple(leg.name for leg in robot.legs) == leg_names
    model = robot.model
    first_foot = model.frames[robot.legs[0].foot_frame_id]
    assert model.frames[first_foot.parentFrame].name == foot_link          # on the URDF's own foot link

    # stance: base level, feet on the ground, knees bent, each contact point where its foot link
    # hangs at the zero configuration (the hips' lateral offsets respected)
    q = robot.q_nominal
    feet = robot.foot_positions(q)[0]
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=5e-4)
    data = model.createData()
    zero = pin.neutral(model)
    zero[2] = q[2]
    pin.framesForwardKinematics(model, data, zero)
    hanging = np.array([data.oMf[model.frames[leg.foot_frame_id].parentFrame].translation for leg in robot.legs])
    np.testing.assert_allclose(feet[:, :2], hanging[:, :2], atol=0.01)
    stretched = [np.linalg.norm(data.oMi[model.getJointId(leg.joint_names[1])].translation - foot)
                 for leg, foot in zip(robot.legs, hanging)]                       # legs straight at zero
    pin.framesForwardKinematics(model, data, q)
    for leg, foot, length in zip(robot.legs, feet, stretched):
        hip = data.oMi[model.getJointId(leg.joint_names[1])].translation
        assert np.linalg.norm(foot - hip) < 0.9 * length                           # knees bent
    assert np.all(robot.upper - robot.lower < 2 * math.pi)                          # physical ranges only

    # centroidal section: pinocchio link by link, not the drafting code's ccrba
    c = robot.centroidal
    mass, com, inertia = _independent_body(model, q)
    assert c.mass == pytest.approx(mass, rel=1e-6)
    np.testing.assert_allclose(c.com_offset, com - q[:3], atol=1e-4)
    np.testing.assert_allclose(c.inertia, inertia, atol=1e-4 * np.abs(inertia).max() + 1e-6)
    np.testing.assert_allclose(c.nominal_feet, feet - q[:3], atol=2e-4)
    assert np.all(c.range_of_motion > 0.02 * robot.leg_length)
    assert 0 < c.max_normal_force <= 4 * mass * GRAVITY + 1


@pytest.mark.parametrize("name", ["anymal_b", "anymal_c", "hyq", "go1"])
def test_drafted_torque_limits_are_the_urdf_efforts_and_bound_the_forces(name, drafted, published_robots):
    """Each leg's drafted torque limits are its joints' efforts as pinocchio reads the URDF, in the
    leg's joint order; the normal force is only capped (4 robot weights). The planner's torques for
    a foot force are pinocchio's Jᵀ f there (the statics the limits bound)."""
    from legplan.dyn.problem import DynParams
    from legplan.dyn.tasks import centroidal_model

    robot = load_robot(drafted[name][0])
    c = robot.centroidal
    urdf = pin.buildModelFromUrdf(str(published_robots / ROBOTS[name][0]), pin.JointModelFreeFlyer())
    for leg, limits in zip(robot.legs, c.torque_limits):
        efforts = [urdf.effortLimit[urdf.idx_vs[urdf.getJointId(joint)]] for joint in leg.joint_names]
        np.testing.assert_array_equal(limits, efforts)
        assert np.all(limits > 0)
    assert c.max_normal_force == math.floor(4 * robot.mass * GRAVITY)
    model = centroidal_model(robot, DynParams())
    f = np.array([20.0, -10.0, robot.mass * GRAVITY / 2])
    tau, _, _, joints = model.leg_chains.foot_torques(0, c.nominal_feet[:1], f[None], model.leg_chains.nominal(0, 1))
    data = robot.model.createData()
    q = robot.q_nominal.copy()
    q[:3], q[3:7] = 0.0, [0, 0, 0, 1]
    indices = [robot.model.idx_qs[robot.model.getJointId(j)] for j in robot.legs[0].joint_names]
    np.testing.assert_allclose(joints[0], q[indices], atol=1e-3)      # the stance's knee side
    q[indices] = joints[0]
    jac = pin.computeFrameJacobian(robot.model, data, q, robot.legs[0].foot_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    np.testing.assert_allclose(data.oMf[robot.legs[0].foot_frame_id].translation, c.nominal_feet[0], atol=1e-9)
    np.testing.assert_allclose(tau[0], jac[:, list(robot.legs[0].joint_idx_v)].T @ f, rtol=1e-9, atol=1e-9)


def test_solo12_placeholder_efforts_are_flagged_and_the_force_capped(drafted):
    path, warnings = drafted["solo12"]
    assert any("placeholders" in w and "max_normal_force" in w for w in warnings)
    robot = load_robot(path)
    assert robot.centroidal.max_normal_force == math.floor(4 * robot.mass * GRAVITY)
    assert robot.centroidal.torque_limits is None          # placeholders bound nothing
    assert torque_limits(robot) is None                     # nor does the planner, the check or the simulator
    np.testing.assert_array_equal(joint_efforts(robot), robot.model.effortLimit[6:])
    flagged = [f for f in check_robot(robot) if f.subject == "centroidal.max_normal_force"]
    assert [f.severity for f in flagged] == ["warning"] and "placeholders" in flagged[0].message


def test_anymal_b_limits_of_9_42_rad_are_replaced_with_a_warning(drafted):
    path, warnings = drafted["anymal_b"]
    assert any("12 revolute joints have ranges of 2π or more" in w for w in warnings)
    robot = load_robot(path)
    for leg in robot.legs:
        knee = leg.joint_idx[-1]
        nominal = robot.q_nominal[7 + knee]
        # the knee keeps its nominal bend side: its range never reaches the stretched leg (0 here)
        assert robot.lower[knee] * robot.upper[knee] > 0 and robot.lower[knee] <= nominal <= robot.upper[knee]


def test_hyq_com_offset_is_drafted(drafted):
    """HyQ's CoM lies centimetres from its base origin: the draft says where."""
    c = load_robot(drafted["hyq"][0]).centroidal
    assert np.linalg.norm(c.com_offset) > 0.03


def test_anymal_b_flying_trot_plans_inside_its_joint_torques(drafted):
    """ANYmal B as drafted (no edits) plans TOWR's flying trot over one body length on flat ground:
    its feet push harder than the one normal-force bound its efforts allow at the nominal stance
    with vertical forces (what the scalar draft used to say, which left the trot infeasible), yet
    the independent check finds every joint inside its URDF effort."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots.rigid_body import leg_forces
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate import check_trajectory

    robot = load_robot(drafted["anymal_b"][0])
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    terrain = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    model = centroidal_model(robot, DynParams())
    length = float(np.ptp(model.nominal_feet[:, 0]))
    result = plan(DynTask((0, 0, 0), (length, 0, 0), "trot", 4, 2.4), model, TerrainModel(terrain), DynParams())
    assert result.success, result.reason
    check = check_trajectory(result.samples, model, terrain, robot, node_times=result.problem.form.knots)
    assert check.ok, check.failures()
    assert check.tolerance["joint_torque"] == pytest.approx(1.001) and 0.8 < check.worst["joint_torque"] <= 1.001
    assert result.samples["forces"][..., 2].max() > leg_forces(robot).force.min()


def test_robot_show_prints_the_torque_limits(drafted):
    """`robot show` prints every leg's torque limits joint by joint (text and JSON), and says when
    there are none (Solo12's placeholder efforts)."""
    import json

    from click.testing import CliRunner

    from legplan.cli.main import cli

    robot = load_robot(drafted["go1"][0])
    shown = CliRunner().invoke(cli, ["robot", "show", str(drafted["go1"][0])])
    assert shown.exit_code == 0, shown.output
    for leg, limits in zip(robot.legs, robot.centroidal.torque_limits):
        line = next(row for row in shown.output.splitlines() if row.strip().startswith(f"torque limits {leg.name} "))
        assert line.split(": ", 1)[1] == ", ".join(f"{joint} {limit:g}" for joint, limit in zip(leg.joint_names, limits))
    as_json = CliRunner().invoke(cli, ["robot", "show", str(drafted["go1"][0]), "--json"])
    limits = json.loads(as_json.output)["centroidal"]["torque_limits"]
    assert limits == {leg.name: list(map(float, values))
                      for leg, values in zip(robot.legs, robot.centroidal.torque_limits)}
    solo = CliRunner().invoke(cli, ["robot", "show", str(drafted["solo12"][0]), "--json"])
    assert json.loads(solo.output)["centroidal"]["torque_limits"] is None
    assert "torque limits: none" in CliRunner().invoke(cli, ["robot", "show", str(drafted["solo12"][0])]).output


def test_go1_stands_at_a_share_of_the_drop_its_calf_limits_allow(drafted):
    """Go1's calf cannot straighten (its URDF limits end 0.89 rad short of straight): the draft
    measures the stance depth against the deepest the foot reaches under its hip inside the joint
    limits, found here by pinocchio FK over a grid of thigh and calf angles, not by the drafting IK
    (both for the URDF's foot link, whose lowest point the contact point is)."""
    from legplan.robots.draft import STANCE_DEPTHS

    robot = load_robot(drafted["go1"][0])
    model, data = robot.model, robot.model.createData()
    leg = robot.legs[0]
    ids = [model.getJointId(j) for j in leg.joint_names]
    q = robot.q_nominal.copy()
    q[:3], q[3:7] = 0.0, [0, 0, 0, 1]
    pin.framesForwardKinematics(model, data, q)
    link = model.frames[leg.foot_frame_id].parentFrame                   # the URDF's FL_foot
    hip, foot = data.oMi[ids[0]].translation.copy(), data.oMf[link].translation.copy()
    thigh, calf = (model.idx_qs[j] for j in ids[1:])
    assert model.upperPositionLimit[calf] < -0.5                       # the straight leg is out of reach
    deepest = 0.0
    for a in np.linspace(model.lowerPositionLimit[thigh], model.upperPositionLimit[thigh], 241):
        for b in np.linspace(model.lowerPositionLimit[calf], model.upperPositionLimit[calf], 241):
            q[thigh], q[calf] = a, b
            pin.framesForwardKinematics(model, data, q)
            p = data.oMf[link].translation
            if abs(p[0] - foot[0]) < 0.004:                          # under the nominal foot (y: the HAA at 0)
                deepest = max(deepest, hip[2] - p[2])
    share = (hip[2] - foot[2]) / deepest
    assert min(abs(share - depth) for depth in STANCE_DEPTHS) < 0.02, share
    assert robot.centroidal.range_of_motion[2] > 0.05                  # room to step down and up


@pytest.mark.parametrize("name", ROBOTS)
def test_the_drafted_range_of_motion_box_is_reached_on_a_finer_grid(name, drafted):
    """Every point of a 5 × 5 × 5 grid on the surface of the drafted box around each nominal foot
    is reached by IK inside the joint limits: more than the corners, edge midpoints and face centres
    the draft proves (HyQ's legs reach all corners of a box whose top edge midpoints they miss)."""
    from legplan.robots.legik import leg_reach

    robot = load_robot(drafted[name][0])
    c = robot.centroidal
    grid = np.linspace(-1.0, 1.0, 5)
    points = np.array([[a, b, d] for a in grid for b in grid for d in grid if max(abs(a), abs(b), abs(d)) == 1.0])
    targets = c.nominal_feet[None, :, :] + (points * c.range_of_motion)[:, None, :]
    reach = leg_reach(robot, np.zeros((len(points), 3)), np.tile(np.eye(3), (len(points), 1, 1)), targets)
    assert reach.reachable.all(), points[~reach.reachable.all(axis=1)]


def test_go1_drafted_from_its_urdf_trots_onto_a_pallet_in_mujoco(drafted, tmp_path):
    """Go1 as `robot init` drafts it (no edits, no options) trots onto a pallet a third of its
    standing height high (the bench's pallet trot: 6 strides in 3.6 s from -1.4 L to 0.9 L), passes
    the independent check and reaches the goal in MuJoCo."""
    import yaml
    from click.testing import CliRunner

    from legplan.artefacts import open_artefact, read_summary
    from legplan.cli.main import cli

    def run(*args):
        return CliRunner().invoke(cli, [str(a) for a in args])

    def summary(path):
        with open_artefact(path) as handle:
            return {key: value for key, (value, _) in read_summary(handle).items()}

    folder = drafted["go1"][0].parent
    feet = yaml.safe_load((folder / "robot.yaml").read_text())["centroidal"]["nominal_feet"]
    length = max(f[0] for f in feet.values()) - min(f[0] for f in feet.values())
    top = round(-sum(f[2] for f in feet.values()) / len(feet) / 3, 3)
    spec = {"name": "pallet", "resolution": 0.01, "ground": 0.0,
            "extent": {"x": [-3 * length, 3 * length], "y": [-2 * length, 2 * length]},
            "primitives": [{"type": "box", "center": [1.1 * length, 0.0], "size": [2.2 * length, 2 * length], "top": top},
                           {"type": "slope", "center": [0.015, 0.0], "size": [0.03, 2 * length], "from": 0.0, "to": top}]}
    (tmp_path / "pallet.yaml").write_text(yaml.safe_dump(spec))
    assert run("map", "build", tmp_path / "pallet.yaml", "-o", tmp_path / "pallet.h5", "-q").exit_code == 0
    traj, sim = tmp_path / "traj.h5", tmp_path / "sim.h5"
    planned = run("dyn", "plan", tmp_path / "pallet.h5", "--robot", folder, "--gait", "trot", "--strides", 6,
                  "--duration", 3.6, "--start", -1.4 * length, 0, 0, "--goal", 0.9 * length, 0, 0, "-o", traj, "-q")
    assert planned.exit_code == 0, planned.output
    assert summary(traj)["check_passed"] == 1
    simulated = run("dyn", "simulate", traj, tmp_path / "pallet.h5", "-o", sim, "-q")
    result = summary(sim)
    assert simulated.exit_code == 0 and result["falls"] == 0 and result["succeeded"] == 1, simulated.output
