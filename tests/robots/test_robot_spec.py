"""robot.yaml validation: one-line SpecErrors naming the file and the field; the toy robot works."""

import copy

import numpy as np
import pinocchio as pin
import pytest
from robot_helpers import TOY_HIP, TOY_LINK, toy_centroidal, toy_spec, write_toy_robot

from legplan.errors import LegplanError, SpecError
from legplan.robots import load_robot, resolve_robot


def test_toy_robot_loads_and_works(toy):
    """Any free-flyer URDF + robot.yaml: 4 legs of 2 joints, other names, other frame names."""
    assert (toy.nq, toy.nv, toy.n_joints, toy.n_legs) == (15, 14, 8, 4)
    assert [leg.foot_frame for leg in toy.legs] == ["toe_a", "toe_b", "toe_c", "toe_d"]
    np.testing.assert_allclose(toy.lower[1::2], -2.0)                  # "{leg}" planning limits
    np.testing.assert_allclose(toy.lower[0::2], -2.5)                  # URDF limits elsewhere
    assert toy.spheres.leg_index.tolist() == [-1, -1, 0, 1, 2, 3, 0, 1, 2, 3]
    assert toy.spheres.is_foot.tolist() == [False] * 6 + [True] * 4
    q = toy.q_nominal
    assert q[2] == pytest.approx(2 * TOY_LINK * np.cos(TOY_HIP))
    feet = toy.foot_positions(np.stack([q, q]))
    np.testing.assert_allclose(feet[0, :, :2], [[0.2, 0.1], [0.2, -0.1], [-0.2, 0.1], [-0.2, -0.1]], atol=1e-12)
    assert toy.foot_jacobians(q).shape == (1, 4, 3, 14)
    assert toy.tangent_map(toy.to_vector(q)).shape == (1, 14, 14)
    assert toy.mass == pytest.approx(3.0 + 8 * 0.2)


def _link_feet(spec):
    """Feet given as a link + offset (the knee's child link, 0.15 m along its -z) instead of the toe frames."""
    for leg in spec["legs"]:
        n = leg["name"]
        del leg["foot_frame"]
        leg["foot"] = {"link": f"shank_{n}", "offset": [0.0, 0.0, -TOY_LINK]}
    spec["collision_spheres"][-1]["link"] = "{leg}_foot"
    return spec


def test_foot_as_link_plus_offset_equals_the_urdf_foot_frame(tmp_path, toy):
    robot = load_robot(write_toy_robot(tmp_path / "linkfeet", _link_feet(copy.deepcopy(toy_spec()))))
    assert [leg.foot_frame for leg in robot.legs] == ["a_foot", "b_foot", "c_foot", "d_foot"]
    frame = robot.model.frames[robot.legs[0].foot_frame_id]
    assert frame.type == pin.FrameType.OP_FRAME and robot.model.names[frame.parentJoint] == "knee_a"
    rng = np.random.default_rng(3)
    Q = np.repeat(toy.q_nominal[None], 5, axis=0)
    Q[:, 7:] += rng.uniform(-0.3, 0.3, (5, 8))
    np.testing.assert_allclose(robot.foot_positions(Q), toy.foot_positions(Q), atol=1e-12)
    np.testing.assert_allclose(robot.foot_jacobians(Q), toy.foot_jacobians(Q), atol=1e-12)
    np.testing.assert_allclose(robot.sphere_centres(Q), toy.sphere_centres(Q), atol=1e-12)
    assert robot.spheres.is_foot.tolist() == toy.spheres.is_foot.tolist()


def _broken(tmp_path, edit):
    spec = copy.deepcopy(toy_spec())
    edit(spec)
    return write_toy_robot(tmp_path / "bad", spec)


CASES = [
    ("unknown foot frame", lambda s: s["legs"][1].update(foot_frame="toe_x"), r"legs\[1\]\.foot_frame.*toe_x"),
    ("foot frame on another leg", lambda s: s["legs"][0].update(foot_frame="toe_b"), r"legs\[0\]\.foot_frame"),
    ("foot and foot_frame", lambda s: s["legs"][1].update(foot={"link": "shank_b"}), r"legs\[1\]\.foot'.*exactly one"),
    ("foot on unknown link", lambda s: _link_feet(s)["legs"][2]["foot"].update(link="paw_c"),
     r"legs\[2\]\.foot\.link.*paw_c"),
    ("foot on another leg's link", lambda s: _link_feet(s)["legs"][0]["foot"].update(link="shank_b"),
     r"legs\[0\]\.foot\.link.*knee_a"),
    ("foot offset not 3 numbers", lambda s: _link_feet(s)["legs"][3]["foot"].update(offset=[0, 0]),
     r"legs\[3\]\.foot\.offset"),
    ("foot frame name taken", lambda s: _link_feet(s)["legs"][0]["foot"].update(frame="toe_b"),
     r"legs\[0\]\.foot\.frame.*toe_b"),
    ("sphere on missing link", lambda s: s["collision_spheres"][0].update(link="chassis"),
     r"collision_spheres\[0\]\.link.*chassis"),
    ("negative radius", lambda s: s["collision_spheres"][1].update(radius=-0.1),
     r"collision_spheres\[1\]\.radius.*> 0"),
    ("offset not 3 numbers", lambda s: s["collision_spheres"][2].update(offset=[0, 1]),
     r"collision_spheres\[2\]\.offset"),
    ("joints not in any leg", lambda s: s["legs"].pop(), r"'legs'.*6 joints.*8 actuated.*hip_d, knee_d"),
    ("unknown joint", lambda s: s["legs"][2]["joints"].__setitem__(1, "elbow_c"), r"legs\[2\]\.joints\[1\].*elbow_c"),
    ("joint twice", lambda s: s["legs"][1]["joints"].__setitem__(0, "hip_a"), r"legs\[1\]\.joints\[0\].*already"),
    ("not a chain", lambda s: s["legs"][0].update(joints=["knee_a", "hip_a"]), r"legs\[0\]\.joints\[0\].*chain"),
    ("missing legs", lambda s: s.pop("legs"), r"field 'legs' is missing"),
    ("missing nominal", lambda s: s.pop("nominal"), r"field 'nominal' is missing"),
    ("missing base height", lambda s: s["nominal"].pop("base_height"), r"nominal\.base_height' is missing"),
    ("feet off the ground", lambda s: s["nominal"].update(base_height=0.5), r"nominal\.base_height.*toe_a.*z = 0"),
    ("nominal outside limits", lambda s: s["nominal"].update(joints=[0.5, 0.0]), r"nominal\.joints.*knee_a"),
    ("wrong nominal length", lambda s: s["nominal"].update(joints=[0.5, -1.0, 0.0]), r"nominal\.joints"),
    ("limit outside URDF", lambda s: s["joint_limits"].update({"hip_a": [-3.0, 1.0]}),
     r"joint_limits\.hip_a.*outside the URDF limits"),
    ("limit on unknown joint", lambda s: s["joint_limits"].update({"wrist": [-1.0, 1.0]}),
     r"joint_limits\.wrist.*unknown joint"),
    ("reversed limits", lambda s: s["joint_limits"].update({"hip_b": [1.0, -1.0]}), r"joint_limits\.hip_b.*<"),
    ("missing urdf", lambda s: s.update(urdf="nope.urdf"), r"field 'urdf'.*missing file"),
    ("navigation limits missing key", lambda s: s.update(navigation={
        "footprint": [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]], "limits": {"v_x_max": 1.0}}),
     r"navigation\.limits\.v_x_min' is missing"),
    ("navigation radius wrong", lambda s: s.update(navigation={
        "footprint": [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]], "inscribed_radius": 0.3,
        "limits": {}}), r"navigation\.inscribed_radius.*0\.2000"),
]



def _centroidal(edit):
    """An edit of a valid toy `centroidal` section (legplan.robots.centroidal)."""
    def apply(spec):
        spec["centroidal"] = toy_centroidal()
        edit(spec["centroidal"])
    return apply


CASES += [(f"centroidal: {name}", _centroidal(edit), pattern) for name, edit, pattern in [
    ("negative mass", lambda c: c.update(mass=-1.0), r"'centroidal\.mass' must be > 0"),
    ("mass not the URDF's", lambda c: c.update(mass=5.0),
     r"'centroidal\.mass' is 5 kg but the URDF's links sum to 4\.6 kg"),
    ("inertia not positive definite", lambda c: c["inertia"].update(ixx=-0.05),
     r"'centroidal\.inertia' must be positive definite"),
    ("inertia no rigid body's", lambda c: c["inertia"].update(izz=0.5), r"'centroidal\.inertia' is no rigid body's"),
    ("inertia key missing", lambda c: c["inertia"].pop("iyz"), r"'centroidal\.inertia\.iyz' is missing"),
    ("inertia key unknown", lambda c: c["inertia"].update(iyx=0.0), r"'centroidal\.inertia\.iyx' is unknown"),
    ("missing leg", lambda c: c["nominal_feet"].pop("c"), r"'centroidal\.nominal_feet\.c' is missing"),
    ("unknown leg", lambda c: c["nominal_feet"].update(e=[0, 0, -0.2]), r"'centroidal\.nominal_feet\.e' names no leg"),
    ("foot not 3 numbers", lambda c: c["nominal_feet"].update(a=[0.2, 0.1]),
     r"'centroidal\.nominal_feet\.a' must be a list of 3"),
    ("foot above the base", lambda c: c["nominal_feet"].update(b=[0.2, -0.1, 0.1]),
     r"'centroidal\.nominal_feet\.b' must be below the base"),
    ("zero range of motion", lambda c: c.update(range_of_motion=[0.05, 0.0, 0.03]),
     r"'centroidal\.range_of_motion\[1\]' must be > 0"),
    ("negative max force", lambda c: c.update(max_normal_force=-10), r"'centroidal\.max_normal_force' must be > 0"),
    ("zero friction", lambda c: c.update(friction=0), r"'centroidal\.friction' must be > 0"),
    ("friction missing", lambda c: c.pop("friction"), r"'centroidal\.friction' is missing"),
    ("unknown key", lambda c: c.update(frcition=0.5), r"'centroidal\.frcition' is unknown"),
]]
CASES.append(("centroidal: not a mapping", lambda s: s.update(centroidal=[1, 2]),
              r"field 'centroidal' must be a mapping"))


@pytest.mark.parametrize("edit,pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_spec_errors_name_file_and_field(tmp_path, edit, pattern):
    path = _broken(tmp_path, edit)
    with pytest.raises(SpecError, match=pattern) as info:
        load_robot(path)
    message = str(info.value)
    assert message.startswith(f"{path}: field '") and "\n" not in message


def test_yaml_syntax_and_unknown_robot(tmp_path):
    folder = tmp_path / "broken"
    write_toy_robot(folder)
    (folder / "robot.yaml").write_text("legs: [unclosed\n")
    with pytest.raises(SpecError, match=r"robot\.yaml: invalid YAML at line"):
        load_robot(folder)
    with pytest.raises(LegplanError, match="unknown robot.*scarab2"):
        resolve_robot("no_such_robot")
    with pytest.raises(LegplanError, match="no such robot folder"):
        resolve_robot(tmp_path / "nothing" / "robot.yaml")
