"""The MuJoCo model from typical ROS URDFs (issue 33 item 4): example-robot-data's quadrupeds as
published, `package://` resolution (next to the URDF, --package-path, ROS_PACKAGE_PATH), inertia
repair with a warning naming the links, the contact policy, effort/velocity overrides, and each
unfixable case as one bad-input line (exit 2, nothing written)."""

import shutil
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from click.testing import CliRunner
from published_robots import PUBLISHED, draft, robots_dir
from stance import standing

from legplan.cli.main import cli
from legplan.errors import LegplanError
from legplan.robots import load_robot
from legplan.sim.model import ModelOptions, build_model
from legplan.robots.packages import UnresolvedUri, resolve_uri
from legplan.sim.run import SimParams, simulate
from legplan.sim.urdf_text import prepare_urdf
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap

GRID = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 101))
FLAT = terrain_from_heightmap(np.zeros(GRID.shape), GRID, name="flat")


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def published(tmp_path_factory):
    folder = tmp_path_factory.mktemp("published")
    return {name: load_robot(draft(name, folder / name)) for name in PUBLISHED}


@pytest.mark.parametrize("name", list(PUBLISHED))
def test_a_published_quadruped_builds_from_its_urdf_and_stands(published, name):
    """As published: no edited URDF. Masses as the URDF's; contacts only robot.yaml's spheres (no
    false trunk contact at t = 0); joint limits and damping from the URDF; standing holds."""
    robot = published[name]
    sim = build_model(robot, FLAT, 0.5)
    model = sim.model
    assert float(model.body_subtreemass[1]) == pytest.approx(pin.computeTotalMass(robot.model), rel=1e-9)
    assert model.ngeom == len(robot.spheres) + 1                     # the spheres and the terrain only
    np.testing.assert_allclose(sim.effort, robot.model.effortLimit[6:])
    np.testing.assert_allclose(sim.velocity_limit, robot.model.velocityLimit[6:])
    np.testing.assert_allclose(sim.damping, robot.model.damping[6:])
    result = simulate(standing(robot, 0.5), robot, FLAT, SimParams(settle=0.0))
    assert result.success and not result.fell, result.reason
    assert result.unplanned_contacts == [] and result.qp_failures == 0
    assert result.max_position_error < 0.01


def test_unphysical_inertias_are_repaired_with_one_warning_naming_the_links():
    """The links MuJoCo refuses (ANYmal C's cameras and hatch, a dummy base, HyQ's massive zero-tensor
    IMU) are named; the compiled principal moments are positive and satisfy A + B >= C; a link that
    was physical keeps its inertia exactly."""
    urdf = robots_dir() / PUBLISHED["anymal_c"][0]
    prepared = prepare_urdf(urdf)
    assert len(prepared.warnings) == 1
    warning = prepared.warnings[0]
    for link in ("depth_camera_front_camera", "depth_camera_rear_camera", "hatch"):
        assert link in warning
    assert "LF_SHANK" not in warning and str(urdf) in warning
    model = mujoco.MjSpec.from_string(prepared.text).compile()
    moments = np.sort(model.body_inertia[model.body_mass > 0], axis=1)
    assert (moments > 0).all() and (moments[:, 0] + moments[:, 1] >= moments[:, 2] * (1 - 1e-9)).all()
    shank = model.body("LF_SHANK").id
    links = {link.get("name"): link for link in ET.parse(urdf).getroot().iter("link")}
    values = {k: float(v) for k, v in links["LF_SHANK"].find("inertial/inertia").attrib.items()}
    tensor = np.array([[values["ixx"], values["ixy"], values["ixz"]], [values["ixy"], values["iyy"], values["iyz"]],
                       [values["ixz"], values["iyz"], values["izz"]]])
    assert np.sort(model.body_inertia[shank]) == pytest.approx(np.linalg.eigvalsh(tensor), rel=1e-9)


def _urdf(tmp_path, inertia='ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"', mass="1.0", extra=""):
    path = tmp_path / "bot.urdf"
    path.write_text(f'<robot name="bot"><link name="body"><inertial><mass value="{mass}"/><inertia {inertia}/>'
                    f'</inertial>{extra}</link></robot>')
    return path


@pytest.mark.parametrize("mass, inertia", [
    ("-1.0", 'ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"'),        # negative mass
    ("1.0", 'ixx="nan" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"'),          # not finite
    ("inf", 'ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"'),         # infinite mass
    ("1.0", 'ixx="abc" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"'),          # not a number
])
def test_an_inertial_that_cannot_be_repaired_is_bad_input(tmp_path, mass, inertia):
    with pytest.raises(LegplanError, match=r"bot\.urdf: link 'body': <inertial>"):
        prepare_urdf(_urdf(tmp_path, inertia, mass))


def test_package_uris_resolve_next_to_the_urdf_by_option_and_by_ros_package_path(tmp_path, monkeypatch):
    # next to the URDF: example-robot-data's own package:// meshes
    urdf = robots_dir() / PUBLISHED["hyq"][0]
    uri = "package://example-robot-data/robots/hyq_description/meshes/trunk/trunk.dae"
    assert resolve_uri(uri, urdf) == (robots_dir() / "hyq_description/meshes/trunk/trunk.dae").resolve()
    # a package elsewhere: not found until named by --package-path, or by ROS_PACKAGE_PATH
    shared = tmp_path / "ws" / "src"
    (shared / "my_robot" / "meshes").mkdir(parents=True)
    (shared / "my_robot" / "meshes" / "leg.stl").write_bytes(b"solid\n")
    urdf = tmp_path / "elsewhere" / "robot.urdf"
    urdf.parent.mkdir()
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(UnresolvedUri, match="my_robot"):
        resolve_uri("package://my_robot/meshes/leg.stl", urdf)
    assert resolve_uri("package://my_robot/meshes/leg.stl", urdf, [shared]) == shared / "my_robot/meshes/leg.stl"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "nothing") + ":" + str(shared))
    assert resolve_uri("package://my_robot/meshes/leg.stl", urdf) == shared / "my_robot/meshes/leg.stl"
    # a folder whose package.xml names the package, relative and file:// paths
    (shared / "renamed").mkdir()
    (shared / "renamed" / "package.xml").write_text("<package><name>other_name</name></package>")
    (shared / "renamed" / "a.stl").write_bytes(b"solid\n")
    assert resolve_uri("package://other_name/a.stl", urdf, [shared / "renamed"]) == shared / "renamed/a.stl"
    assert resolve_uri("../ws/src/renamed/a.stl", urdf) == shared / "renamed/a.stl"
    assert resolve_uri(f"file://{shared / 'renamed/a.stl'}", urdf) == shared / "renamed/a.stl"
    with pytest.raises(UnresolvedUri):
        resolve_uri("package://my_robot/meshes/missing.stl", urdf, [shared])


def test_the_urdf_collision_geometry_touches_the_terrain_only_when_asked(published):
    """HyQ's collision geometry (Collada meshes, loaded by coal) is off by default, and with
    `urdf_collision` it is built, touches the terrain only, and counts on the trunk."""
    robot = published["hyq"]
    off = build_model(robot, FLAT, 0.5)
    on = build_model(robot, FLAT, 0.5, ModelOptions(urdf_collision=True))
    assert off.model.nmesh == 0 and on.model.nmesh > 0
    extra = sorted(set(range(on.model.ngeom)) - {on.terrain_geom, *on.foot_geoms})
    assert len(extra) == on.model.ngeom - 1 - 4 and set(extra) == set(on.body_geoms.tolist())
    meshes = [g for g in extra if on.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
    assert meshes and all(on.model.geom_contype[g] == 1 and on.model.geom_conaffinity[g] == 0 for g in meshes)
    assert set(off.trunk_geoms.tolist()) < set(on.trunk_geoms.tolist())


def test_effort_and_velocity_overrides_replace_placeholders(published):
    """Solo12's URDF says 1000 N m and 1000 rad/s for every joint (placeholders); overrides by pattern
    replace them, the last match winning; a pattern matching nothing is bad input."""
    robot = published["solo12"]
    assert build_model(robot, FLAT, 0.5).effort == pytest.approx(1000.0)
    sim = build_model(robot, FLAT, 0.5, ModelOptions(effort=(("*", 2.7), ("*_KFE", 3.0)),
                                                    velocity=(("*", 30.0),)))
    kfe = np.array([name.endswith("_KFE") for name in robot.joint_names])
    assert sim.effort[kfe] == pytest.approx(3.0) and sim.effort[~kfe] == pytest.approx(2.7)
    assert sim.model.actuator_ctrlrange[:, 1] == pytest.approx(sim.effort)
    assert sim.velocity_limit == pytest.approx(30.0)
    with pytest.raises(LegplanError, match=r"--effort knee\*=3: the pattern matches no joint"):
        build_model(robot, FLAT, 0.5, ModelOptions(effort=(("knee*", 3.0),)))


@pytest.fixture(scope="module")
def anymal_copy(tmp_path_factory):
    """robots/anymal copied as robot 'anymal_mesh' (found by name through LEGPLAN_ROBOTS: traj.h5
    records the robot's name) with a URDF naming a collision mesh of an unknown ROS package, and a
    short trot planned for it on a flat map."""
    folder = tmp_path_factory.mktemp("anymal_mesh") / "anymal_mesh"
    shutil.copytree(load_robot("anymal").yaml_path.parent, folder)
    spec = (folder / "robot.yaml").read_text().replace("name: anymal\n", "name: anymal_mesh\n")
    (folder / "robot.yaml").write_text(spec)
    urdf = (folder / "robot.urdf").read_text()
    head = urdf.index("</link>")
    (folder / "robot.urdf").write_text(urdf[:head] + '<collision><geometry><mesh filename="package://no_such_pkg/'
                                       'meshes/base.stl"/></geometry></collision>' + urdf[head:])
    maps = folder.parent / "flat.h5"
    save_map(FLAT, maps)
    traj = folder.parent / "traj.h5"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("LEGPLAN_ROBOTS", str(folder.parent))
        result = invoke("dyn", "plan", maps, "--robot", "anymal_mesh", "--start", 0, 0, 0, "--goal", 0.2, 0, 0,
                        "--strides", 2, "--duration", 1.2, "-o", traj, "-q")
    assert result.exit_code == 0, result.output
    return traj, maps


@pytest.mark.parametrize("case", ["package", "effort_pattern", "effort_value", "push", "mass_scale", "package_path"])
def test_a_model_that_cannot_be_built_is_one_bad_input_line(anymal_copy, tmp_path, monkeypatch, case):
    traj, maps = anymal_copy
    monkeypatch.setenv("LEGPLAN_ROBOTS", str(traj.parent))
    out = tmp_path / "sim.h5"
    extra = {"package": ["--urdf-collision"], "effort_pattern": ["--effort", "nothing_*=3"],
             "effort_value": ["--effort", "haa_lf=0"], "push": ["--push", 1, 0, 50],
             "mass_scale": ["--mass-scale", 0], "package_path": ["--package-path", tmp_path / "missing"]}[case]
    result = invoke("dyn", "simulate", traj, maps, "-o", out, *extra)
    assert result.exit_code == 2, result.output
    assert not out.exists()
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) <= 3   # click's usage lines for option errors, else one line
    if case == "package":
        assert "robot.urdf: link 'base_link': collision mesh 'package://no_such_pkg/meshes/base.stl'" in result.output
    if case == "effort_pattern":
        assert "--effort nothing_*=3: the pattern matches no joint" in result.output


def test_drake_rotor_inertia_becomes_armature_in_mujoco_and_the_controller(tmp_path):
    """URDF has no armature; Drake's transmission extension gives rotor inertia × gear ratio²."""
    from robot_helpers import write_toy_robot

    from legplan.sim.controller import WholeBodyController

    folder = tmp_path / "toy"
    write_toy_robot(folder)
    urdf = (folder / "robot.urdf").read_text()
    urdf = urdf.replace('<robot name="toy">', '<robot name="toy" xmlns:drake="http://drake.mit.edu">')
    urdf = urdf.replace("</robot>", '<transmission name="t"><type>transmission_interface/SimpleTransmission</type>'
                        '<joint name="hip_a"/><actuator name="m"><drake:rotor_inertia value="1e-4"/>'
                        '<drake:gear_ratio value="10"/></actuator></transmission></robot>')
    (folder / "robot.urdf").write_text(urdf)
    robot = load_robot(folder / "robot.yaml")
    sim = build_model(robot, FLAT, 0.5)
    hip = robot.joint_names.index("hip_a")
    expected = np.zeros(robot.n_joints)
    expected[hip] = 1e-4 * 10 ** 2
    np.testing.assert_allclose(sim.armature, expected)
    np.testing.assert_allclose(sim.model.dof_armature[sim.dof_index], expected)
    controller = WholeBodyController(robot, sim.effort, 0.5, armature=sim.armature)
    q = robot.q_nominal
    M = pin.crba(controller.model, controller.model.createData(), q)
    M0 = pin.crba(robot.model, robot.model.createData(), q)
    assert M[6 + hip, 6 + hip] - M0[6 + hip, 6 + hip] == pytest.approx(0.01)
    assert np.allclose(np.delete(np.diag(M - M0), 6 + hip), 0.0)
