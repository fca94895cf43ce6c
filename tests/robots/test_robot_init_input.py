"""`robot init` / `robot check` on bad input, by class: one line naming the file and the field,
exit 2, nothing written. Plus the pieces those lines come from (package:// lookup, --foot)."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml
from click.testing import CliRunner
from robot_helpers import write_toy_robot

from legplan.cli.main import cli
from legplan.errors import SpecError
from legplan.robots import load_robot
from legplan.robots.draft import STANCE_DEPTHS, TROT_WEIGHT_SHARE, quadruped_order
from legplan.robots.urdf import read_urdf_links, resolve_mesh

TOY_FEET = [arg for leg in "abcd" for arg in ("--foot", f"{leg}=toe_{leg}")]
MESH = "<collision><geometry><mesh filename=\"{}\"/></geometry></collision>"
INERTIA = '<inertial><mass value="{}"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'
OCTAHEDRON = [(0.015, 0, 0), (-0.015, 0, 0), (0, 0.015, 0), (0, -0.015, 0), (0, 0, 0.015), (0, 0, -0.015)]


def quadruped_urdf(foot: str = '<sphere radius="0.015"/>', effort: float = 20.0) -> str:
    """A 3-DoF quadruped as ROS URDFs write them: HAA about x, HFE and KFE about y, hips 5 cm out
    from the HAA axis, legs hanging at zero, a `<LEG>_foot` link with `foot` geometry, joint
    efforts `effort` (N m)."""
    parts = [f'<robot name="quad"><link name="base">{INERTIA.format(5.0)}<collision><geometry>'
             '<box size="0.4 0.2 0.1"/></geometry></collision></link>']
    for leg, x, y in (("LF", 0.2, 0.1), ("RF", 0.2, -0.1), ("LH", -0.2, 0.1), ("RH", -0.2, -0.1)):
        side = 1 if y > 0 else -1
        chain = [("HAA", "base", f"{leg}_hip", f"{x} {y} 0", "1 0 0", "-0.6 0.6", ""),
                 ("HFE", f"{leg}_hip", f"{leg}_thigh", f"0 {0.05 * side} 0", "0 1 0", "-2 2",
                  '<box size="0.03 0.03 0.15"/>'),
                 ("KFE", f"{leg}_thigh", f"{leg}_shank", "0 0 -0.15", "0 1 0", "-2.6 2.6",
                  '<cylinder radius="0.01" length="0.15"/>')]
        for joint, parent, child, xyz, axis, (lo_hi), shape in chain:
            lo, hi = lo_hi.split()
            parts.append(f'<joint name="{leg}_{joint}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                         f'<origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{lo}" upper="{hi}" effort="{effort:g}" '
                         'velocity="10"/></joint>')
            geometry = f'<collision><origin xyz="0 0 -0.075"/><geometry>{shape}</geometry></collision>' if shape else ""
            parts.append(f'<link name="{child}">{INERTIA.format(0.3)}{geometry}</link>')
        parts.append(f'<joint name="{leg}_foot_fixed" type="fixed"><parent link="{leg}_shank"/><child link="{leg}_foot"/>'
                     f'<origin xyz="0 0 -0.15"/></joint><link name="{leg}_foot">{INERTIA.format(0.01)}'
                     f'<collision><geometry>{foot}</geometry></collision></link>')
    return "".join(parts) + "</robot>"


def test_a_quadruped_urdf_drafts_completely(tmp_path):
    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf())
    out = tmp_path / "quad"
    result = run("robot", "init", urdf, "-o", out)
    assert result.exit_code == 0, result.output
    robot = load_robot(out)
    assert [leg.name for leg in robot.legs] == ["LF", "RF", "LH", "RH"]
    q = robot.q_nominal
    feet = robot.foot_positions(q)[0]
    np.testing.assert_allclose(feet[:, 1], [0.15, -0.15, 0.15, -0.15], atol=1e-3)    # the hips' 5 cm respected
    np.testing.assert_allclose(feet[:, 0], [0.2, 0.2, -0.2, -0.2], atol=1e-3)        # under the hips
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=5e-4)
    depths = [depth * 0.3 + 0.015 for depth in STANCE_DEPTHS]        # shares of the drop, plus the foot ball
    assert min(abs(q[2] - h) for h in depths) < 2e-3
    knees = robot.model.createData()
    pin.forwardKinematics(robot.model, knees, q)
    for leg, foot in zip(robot.legs, feet):                          # bent, towards the body's centre
        knee = knees.oMi[robot.model.getJointId(leg.joint_names[2])].translation
        assert (knee[0] - foot[0]) * np.sign(foot[0]) < -0.02
    contact = robot.model.frames[robot.legs[0].foot_frame_id]
    assert robot.model.frames[contact.parentFrame].name == "LF_foot"
    np.testing.assert_allclose(robot.centroidal.nominal_feet[0], feet[0] - q[:3], atol=2e-4)
    assert robot.centroidal.mass == pytest.approx(5.0 + 4 * (3 * 0.3 + 0.01))
    check = run("robot", "check", out)
    assert check.exit_code == 0 and "quad: 0 errors, 0 warnings" in check.output, check.output


@pytest.mark.parametrize("effort", [20.0, 1.5])
def test_the_stance_depth_is_the_largest_box_whose_legs_hold_a_trot(tmp_path, effort):
    """Of the candidate depths, the draft stands at the one with the largest range-of-motion box
    among those at which every leg pushes a flying trot's weight share inside its efforts: with
    strong joints the box decides; with joints too weak at every depth, the straightest stance
    (where a leg pushes hardest). Each candidate is drafted at its own `--height`, as a user would."""
    from legplan.robots.rigid_body import GRAVITY, leg_forces

    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf(effort=effort))
    out = tmp_path / "quad"
    assert run("robot", "init", urdf, "-o", out).exit_code == 0
    chosen = load_robot(out)
    candidates = []
    for k, depth in enumerate(STANCE_DEPTHS):
        folder = tmp_path / f"at{k}"
        height = depth * 0.3 + 0.015                                        # the drop, plus the foot ball
        assert run("robot", "init", urdf, "-o", folder, "--height", height).exit_code == 0
        robot = load_robot(folder)
        push = leg_forces(robot).force.min()
        candidates.append((push >= TROT_WEIGHT_SHARE * robot.mass * GRAVITY,
                           np.prod(robot.centroidal.range_of_motion), push, robot.q_nominal[2]))
    holding = [c for c in candidates if c[0]]
    best = max(holding, key=lambda c: c[1]) if holding else max(candidates, key=lambda c: c[2])
    assert chosen.q_nominal[2] == pytest.approx(best[3], abs=2e-3)
    if effort < 2:
        assert not holding and chosen.q_nominal[2] == pytest.approx(max(STANCE_DEPTHS) * 0.3 + 0.015, abs=2e-3)
    else:
        assert holding and len({round(c[1], 9) for c in candidates}) == len(candidates)   # the boxes differ


def test_a_mesh_foot_touches_the_ground_with_its_lowest_vertex(tmp_path):
    stl = ["solid foot"]
    for a, b, c in [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]:
        stl += ["facet normal 0 0 0", "outer loop", *(f"vertex {' '.join(map(str, OCTAHEDRON[k]))}" for k in (a, b, c)),
                "endloop", "endfacet"]
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "foot.stl").write_text("\n".join(stl + ["endsolid foot"]) + "\n")
    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf('<mesh filename="meshes/foot.stl"/>'))
    out = tmp_path / "quad"
    assert run("robot", "init", urdf, "-o", out).exit_code == 0
    robot = load_robot(out)
    spec = yaml.safe_load((out / "robot.yaml").read_text())
    offset = np.array(spec["legs"][0]["foot"]["offset"])
    shank = robot.model.frames[robot.model.getFrameId("LF_foot", pin.FrameType.BODY)]
    world = robot.model.frames[robot.legs[0].foot_frame_id]
    assert np.linalg.norm(offset) == pytest.approx(0.015, abs=2e-4)   # the octahedron's bottom vertex
    assert shank.parentJoint == world.parentJoint
    np.testing.assert_allclose(robot.foot_positions(robot.q_nominal)[0, :, 2], 0.0, atol=5e-4)


def run(*args, env=None):
    return CliRunner().invoke(cli, [str(a) for a in args], env=env)


@pytest.fixture
def toy_urdf(tmp_path) -> Path:
    """The toy quadruped's URDF (tests/robot_helpers.py): feet `toe_<leg>` frames without geometry."""
    return write_toy_robot(tmp_path / "toy").parent / "robot.urdf"


def _with_shank_mesh(urdf: Path, filename: str) -> Path:
    text = urdf.read_text().replace('<link name="shank_b">', '<link name="shank_b">' + MESH.format(filename), 1)
    urdf.write_text(text)
    return urdf


def _one_line_exit_2(result, out: Path, *needles):
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert not (out / "robot.yaml").exists()


def test_toy_drafts_with_feet_given_on_the_command_line(toy_urdf, tmp_path):
    """The toy's legs swing in x-z only: no centroidal box (one line), unless asked for none."""
    out = tmp_path / "drafted"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out, *TOY_FEET), out,
                     "centroidal.range_of_motion: the feet cannot move along y", "--no-centroidal")
    result = run("robot", "init", toy_urdf, "-o", out, *TOY_FEET, "--height", "0.25", "--no-centroidal")
    assert result.exit_code == 0, result.output
    robot = load_robot(out)
    assert [leg.name for leg in robot.legs] == ["a", "b", "c", "d"] and robot.centroidal is None
    assert robot.q_nominal[2] == pytest.approx(0.25, abs=1e-3)
    np.testing.assert_allclose(robot.foot_positions(robot.q_nominal)[0, :, 2], 0, atol=5e-4)
    check = run("robot", "check", out)
    assert check.exit_code == 0 and "0 errors" in check.output


@pytest.mark.parametrize("case, args, needles", [
    ("no foot geometry", [], ["robot.urdf: link(s) shank_a, toe_a of joint 'knee_a' have no geometry",
                              "--foot LEG=LINK"]),
    ("unknown foot link", ["--foot", "a=nope"], ["--foot a=nope:", "has no link 'nope'"]),
    ("foot on another leg", ["--foot", "a=toe_b"], ["--foot a=toe_b: link 'toe_b' is not moved by leg a's last joint"]),
    ("foot of no leg", [*TOY_FEET, "--foot", "e=toe_a"], ["--foot e=...: no leg named 'e'"]),
    ("bad foot offset", ["--foot", "a=toe_a:1,2"], ["--foot", "the offset needs 3 numbers"]),
    ("base too high", [*TOY_FEET, "--height", "0.5"], ["cannot put its foot on the ground", "--height 0.500 m"]),
])
def test_toy_bad_options(case, args, needles, toy_urdf, tmp_path):
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out, *args), out, *needles)
    assert not out.exists()


def test_urdf_without_legs(tmp_path):
    urdf = tmp_path / "box.urdf"
    urdf.write_text('<robot name="box"><link name="base"><inertial><mass value="1"/>'
                    '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>')
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", urdf, "-o", out), out, f"{urdf}: no joint below the base link")


def test_a_joint_whose_limit_gives_no_range(tmp_path):
    """A revolute joint whose <limit> leaves out lower and upper (the URDF's default range [0, 0],
    as example-robot-data's quadruped_description writes its knees): one line naming the joint."""
    urdf = tmp_path / "quad.urdf"
    text = quadruped_urdf()
    knee = 'name="RH_KFE" type="revolute">'
    head, tail = text.split(knee)
    urdf.write_text(head + knee + tail.replace('lower="-2.6" upper="2.6" ', "", 1))
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", urdf, "-o", out), out,
                     f"{urdf}: joint 'RH_KFE': its <limit> gives no range (lower 0 = upper 0")


def test_legs_that_branch(toy_urdf, tmp_path):
    text = toy_urdf.read_text().replace("</robot>", '<joint name="claw_a" type="revolute"><parent link="thigh_a"/>'
                                        '<child link="claw_a"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" '
                                        'effort="1" velocity="1"/></joint><link name="claw_a"/></robot>')
    toy_urdf.write_text(text)
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out), out,
                     "the chain from joint 'hip_a' branches at joint 'hip_a'")


def test_missing_mesh(toy_urdf, tmp_path):
    _with_shank_mesh(toy_urdf, "meshes/shank.stl")
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out, *TOY_FEET), out,
                     f"{toy_urdf}: link 'shank_b' mesh 'meshes/shank.stl': no such file")


def test_unresolvable_package(toy_urdf, tmp_path):
    _with_shank_mesh(toy_urdf, "package://nowhere_description/meshes/shank.stl")
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out, *TOY_FEET), out,
                     f"{toy_urdf}: link 'shank_b' mesh 'package://nowhere_description/meshes/shank.stl': "
                     "package 'nowhere_description' not found")


def test_unreadable_mesh(toy_urdf, tmp_path):
    (toy_urdf.parent / "shank.stl").write_bytes(b"\x00\x01 not a mesh")
    _with_shank_mesh(toy_urdf, "shank.stl")
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", toy_urdf, "-o", out, *TOY_FEET), out,
                     f"{toy_urdf}: mesh 'shank.stl'", "cannot be read")


def test_package_lookup_order(tmp_path, monkeypatch):
    """package://NAME/rest: --package-path first, then the URDF's parent folders, then ROS_PACKAGE_PATH."""
    urdf = tmp_path / "ws" / "src" / "bot_description" / "urdf" / "bot.urdf"
    urdf.parent.mkdir(parents=True)
    mesh = urdf.parents[1] / "meshes" / "leg.stl"
    mesh.parent.mkdir()
    mesh.write_text("solid x\nendsolid x\n")
    elsewhere = tmp_path / "elsewhere" / "bot_description" / "meshes" / "leg.stl"
    elsewhere.parent.mkdir(parents=True)
    elsewhere.write_text("solid x\nendsolid x\n")
    name = "package://bot_description/meshes/leg.stl"
    roots = [*urdf.resolve().parents]
    assert resolve_mesh(name, urdf, roots, "leg") == mesh.resolve()                       # the URDF's own package
    assert resolve_mesh(name, urdf, [tmp_path / "elsewhere", *roots], "leg") == elsewhere  # a package path wins
    assert resolve_mesh(name, urdf, [elsewhere.parents[1], *roots], "leg") == elsewhere    # or the package itself
    outside = tmp_path / "outside.urdf"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "elsewhere"))
    outside.write_text('<robot name="b"><link name="leg"><collision><geometry>'
                       f'<mesh filename="{name}"/></geometry></collision></link></robot>')
    assert read_urdf_links(outside).meshes["leg"][0].path == elsewhere
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    with pytest.raises(SpecError, match=r"outside\.urdf: link 'leg' mesh 'package://bot_description/meshes/leg\.stl': "
                       r"package 'bot_description' not found"):
        read_urdf_links(outside)


def test_quadruped_order_by_hips():
    hips = np.array([[-0.3, -0.2, 0], [0.3, 0.2, 0], [-0.3, 0.2, 0], [0.3, -0.2, 0]])
    assert quadruped_order(hips) == [1, 3, 2, 0]                      # LF, RF, LH, RH
    assert quadruped_order(np.array([[0.3, 0.2, 0], [0.3, 0.1, 0], [-0.3, 0.2, 0], [0.3, -0.2, 0]])) == [0, 1, 2, 3]


@pytest.fixture
def drafted_quad(tmp_path) -> Path:
    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf())
    out = tmp_path / "drafted"
    assert run("robot", "init", urdf, "-o", out, "--friction", "0.7").exit_code == 0
    assert load_robot(out).centroidal.friction == 0.7
    return out / "robot.yaml"


@pytest.mark.parametrize("field, edit", [
    ("centroidal.inertia", lambda c: c["inertia"].update(ixx=2 * c["inertia"]["ixx"])),
    ("centroidal.com_offset", lambda c: c.update(com_offset=[0.05, 0, c["com_offset"][2]])),
    ("centroidal.nominal_feet.RF", lambda c: c["nominal_feet"]["RF"].__setitem__(1, c["nominal_feet"]["RF"][1] - 0.2)),
])
def test_a_centroidal_section_contradicting_its_urdf(field, edit, drafted_quad, tmp_path):
    spec = yaml.safe_load(drafted_quad.read_text())
    edit(spec["centroidal"])
    drafted_quad.write_text(yaml.safe_dump(spec))
    shown = run("robot", "show", drafted_quad)                          # every loader refuses it
    assert shown.exit_code == 2 and len(shown.stderr.strip().splitlines()) == 1
    assert f"{drafted_quad}: field '{field}'" in shown.stderr
    flat = tmp_path / "flat.h5"
    assert run("map", "build", Path(__file__).parents[2] / "maps" / "flat.yaml", "-o", flat).exit_code == 0
    planned = run("dyn", "plan", flat, "--robot", drafted_quad.parent, "--start", "0", "0", "0",
                  "--goal", "0.1", "0", "0", "-o", tmp_path / "traj.h5")
    assert planned.exit_code == 2 and f"field '{field}'" in planned.stderr
    assert not (tmp_path / "traj.h5").exists()
    checked = run("robot", "check", drafted_quad)                       # check lists it among its findings
    assert checked.exit_code == 1
    assert any(line.startswith(f"error: {field}: ") for line in checked.output.splitlines()), checked.output


def test_check_reports_a_range_of_motion_out_of_reach(drafted_quad):
    spec = yaml.safe_load(drafted_quad.read_text())
    spec["centroidal"]["range_of_motion"] = [0.2, 0.2, 0.2]              # the legs are 0.3 m long
    drafted_quad.write_text(yaml.safe_dump(spec))
    checked = run("robot", "check", drafted_quad)
    assert checked.exit_code == 1
    lines = [line for line in checked.output.splitlines() if line.startswith("error: centroidal.range_of_motion:")]
    assert len(lines) == 1 and "out of reach inside the joint limits for legs LF (" in lines[0]


def test_continuous_joints_and_massless_urdfs(tmp_path):
    """A wheel-like continuous joint (nq = 2) and a URDF without inertials: one line each."""
    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf().replace('name="RH_KFE" type="revolute"', 'name="RH_KFE" type="continuous"'))
    out = tmp_path / "out"
    _one_line_exit_2(run("robot", "init", urdf, "-o", out), out, f"{urdf}: joint 'RH_KFE' is not a 1-DoF")
    massless = quadruped_urdf()
    for mass in ("5.0", "0.3", "0.01"):
        massless = massless.replace(f'<mass value="{mass}"/>', '<mass value="0"/>')
    urdf.write_text(massless)
    _one_line_exit_2(run("robot", "init", urdf, "-o", out), out, f"{urdf}: centroidal.mass: the URDF's links have no mass")
    assert not out.exists()


def test_dyn_refuses_a_robot_that_is_not_a_quadruped(tmp_path):
    hexapod = Path(__file__).parents[1] / "data" / "hexapod.urdf"
    out = tmp_path / "hexapod"
    assert run("robot", "init", hexapod, "-o", out).exit_code == 0
    flat = tmp_path / "flat.h5"
    assert run("map", "build", Path(__file__).parents[2] / "maps" / "flat.yaml", "-o", flat).exit_code == 0
    planned = run("dyn", "plan", flat, "--robot", out, "--start", "0", "0", "0", "--goal", "0.1", "0", "0",
                  "-o", tmp_path / "traj.h5")
    assert planned.exit_code == 2 and len(planned.stderr.strip().splitlines()) == 1
    assert f"{out / 'robot.yaml'}: field 'legs' lists 6 legs; `legplan dyn` plans quadrupeds" in planned.stderr
    assert not (tmp_path / "traj.h5").exists()


def test_leg_stance_jacobian_matches_finite_differences(tmp_path):
    from legplan.robots.draft import LegStance

    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf())
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    chain = [model.getJointId(name) for name in ("LH_HAA", "LH_HFE", "LH_KFE")]
    foot = model.getFrameId("LH_foot", pin.FrameType.BODY)
    problem = LegStance(model, chain, foot, [-0.2, 0.15], 0.24)
    x = np.array([0.1, -0.6, 1.1])
    numeric = np.column_stack([(problem.residuals(x + h) - problem.residuals(x - h)) / 2e-6
                               for h in np.eye(3) * 1e-6])
    np.testing.assert_allclose(problem.jacobian(x), numeric, atol=1e-6)


def test_leg_forces_equal_effort_over_lever(tmp_path):
    """A vertical push f at the foot loads each pitch joint with f times the horizontal distance from
    its axis to the foot, and the HAA joint with f times the lateral one: the weakest sets f."""
    from legplan.robots.rigid_body import leg_forces

    urdf = tmp_path / "quad.urdf"
    urdf.write_text(quadruped_urdf())
    out = tmp_path / "quad"
    assert run("robot", "init", urdf, "-o", out).exit_code == 0
    robot = load_robot(out)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_nominal)
    forces = leg_forces(robot)
    for k, leg in enumerate(robot.legs):
        foot = data.oMf[leg.foot_frame_id].translation
        axes = [data.oMi[robot.model.getJointId(name)].translation for name in leg.joint_names]
        levers = [abs(foot[1] - axes[0][1]), abs(foot[0] - axes[1][0]), abs(foot[0] - axes[2][0])]
        assert forces.force[k] == pytest.approx(20.0 / max(levers), rel=1e-6)      # every effort is 20 N m
    assert forces.placeholder == ()
