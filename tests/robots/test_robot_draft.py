"""`robot init`'s drafting rules on tests/data/hexapod.urdf, `robot check`'s findings, joint axes."""

import copy
import hashlib
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml
from robot_helpers import TOY_HIP, TOY_LINK, toy_spec, write_toy_robot

from legplan.errors import LegplanError
from legplan.robots import load_robot
from legplan.robots.check import check_robot
from legplan.robots.draft import leg_names, primitive_spheres, write_draft
from legplan.robots.draw import joint_axes
from legplan.robots.urdf import Primitive

HEXAPOD = Path(__file__).parents[1] / "data" / "hexapod.urdf"
TIBIA = 0.138   # m, the hexapod's tibia cylinder length: its far end is the foot


@pytest.fixture(scope="module")
def drafted(tmp_path_factory):
    before = hashlib.sha256(HEXAPOD.read_bytes()).hexdigest()
    path, draft = write_draft(HEXAPOD, tmp_path_factory.mktemp("robots") / "phantom")
    assert draft.warnings == ()
    assert hashlib.sha256(HEXAPOD.read_bytes()).hexdigest() == before      # the URDF is not edited
    return path


def test_draft_finds_legs_feet_limits_and_a_stance_on_the_ground(drafted):
    urdf = pin.buildModelFromUrdf(str(HEXAPOD), pin.JointModelFreeFlyer())
    assert not any("foot" in frame.name or "tip" in frame.name for frame in urdf.frames)  # no foot frames
    assert {urdf.frames[k].name for k in range(len(urdf.frames))} >= {"tibia_lf", "tibia_rr"}
    spec = yaml.safe_load(drafted.read_text())
    assert spec["name"] == "phantom"
    assert [leg["name"] for leg in spec["legs"]] == ["lf", "lm", "lr", "rf", "rm", "rr"]
    assert spec["legs"][0]["joints"] == ["coxa_joint_lf", "femur_joint_lf", "tibia_joint_lf"]
    assert spec["legs"][3]["foot"] == {"link": "tibia_rf", "offset": [TIBIA, 0, 0]}
    assert spec["joint_limits"]["femur_joint_lm"] == [-1.8, 1.8]
    robot = load_robot(drafted)
    q = robot.q_nominal
    feet = robot.foot_positions(q)[0]
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=5e-4)
    assert q[2] > 0.1 and np.allclose(q[3:7], [0, 0, 0, 1])
    # feet out from the hips, knees within 1 cm of the femur joints' height (the draft keeps the
    # knee-highest solution; a knee below the foot's reach would be the other IK branch)
    origins, _ = joint_axes(robot, q)
    assert np.all(origins[2::3, 2] >= origins[1::3, 2] - 0.01)
    hips = origins[0::3]
    assert np.all(np.linalg.norm(feet[:, :2], axis=1) > np.linalg.norm(hips[:, :2], axis=1) + 0.05)
    # no non-foot sphere in the ground, one foot sphere per leg
    heights = robot.sphere_centres(q)[0][:, 2] - robot.spheres.radii
    assert heights[~robot.spheres.is_foot].min() >= 0.02 * robot.leg_length / 0.241 - 1e-9
    assert robot.spheres.is_foot.sum() == 6


def test_drafted_robot_passes_check_and_shipped_robots_too(drafted, scarab2, jueying, anymal):
    for robot in (load_robot(drafted), scarab2, jueying, anymal):
        assert [f for f in check_robot(robot) if f.severity == "error"] == [], robot.name


def test_check_finds_a_foot_moved_off_the_far_end(drafted, tmp_path):
    spec = yaml.safe_load(drafted.read_text())
    spec["urdf"] = str(HEXAPOD)
    spec["legs"][1]["foot"]["offset"] = [TIBIA, 0.03, 0]   # 3 cm along the pitch axis: same height
    (tmp_path / "robot.yaml").write_text(yaml.safe_dump(spec))
    with pytest.raises(LegplanError, match=r"field 'centroidal\.nominal_feet\.lm' is \(0\.000, 0\.228, -0\.143\) m but "
                       r"the nominal stance puts the foot at \(-0\.030, 0\.228, -0\.143\) m \(30\.0 mm away\)"):
        load_robot(tmp_path)                                # the centroidal section no longer matches
    del spec["centroidal"]
    (tmp_path / "robot.yaml").write_text(yaml.safe_dump(spec))
    findings = check_robot(load_robot(tmp_path))
    assert [(f.severity, f.subject) for f in findings] == [("warning", "leg lm")]
    assert "30.0 mm from where robot init puts the foot (link 'tibia_lm''s geometry" in findings[0].message


def _toy_check(tmp_path, edit=None, urdf_edit=None):
    spec = copy.deepcopy(toy_spec())
    if edit:
        edit(spec)
    path = write_toy_robot(tmp_path / "toy", spec)
    if urdf_edit:
        urdf = path.parent / "robot.urdf"
        urdf.write_text(urdf_edit(urdf.read_text()))
    return check_robot(load_robot(path))


def test_check_errors_and_warnings_on_the_toy(tmp_path):
    assert _toy_check(tmp_path / "ok") == []
    sunk = _toy_check(tmp_path / "sunk", lambda s: s["collision_spheres"][2].update(offset=[0, 0, -0.14]))
    assert [(f.severity, f.subject) for f in sunk] == [("error", f"sphere {k} (shank_{n})")
                                                        for k, n in zip(range(2, 6), "abcd")]
    assert "mm in the ground" in sunk[0].message

    def knee_feet(spec):          # feet at the knees: on the ground only with the base lowered
        for leg in spec["legs"]:
            leg.pop("foot_frame")
            leg["foot"] = {"link": f"shank_{leg['name']}", "offset": [0, 0, 0]}
        spec["collision_spheres"] = spec["collision_spheres"][:2]
        spec["nominal"]["base_height"] = TOY_LINK * math.cos(TOY_HIP)
    at_knee = _toy_check(tmp_path / "knee", knee_feet)
    assert {f.subject for f in at_knee if "distal end" in f.message} == {"leg a", "leg b", "leg c", "leg d"}
    heavy = _toy_check(tmp_path / "inertia", urdf_edit=lambda text: text.replace('ixx="0.01"', 'ixx="0.1"', 1))
    assert [(f.severity, f.subject) for f in heavy] == [("warning", "link trunk")]
    assert "triangle inequality" in heavy[0].message


def test_leg_names_and_spheres_of_primitives():
    assert leg_names([["coxa_lf", "femur_lf"], ["coxa_rf", "femur_rf"]]) == ["lf", "rf"]
    assert leg_names([["LF_HAA", "LF_KFE"], ["RF_HAA", "RF_KFE"]]) == ["LF", "RF"]   # as the URDF writes them
    assert leg_names([["a", "b"], ["c", "d"]]) == ["leg0", "leg1"]
    box = Primitive("box", (0.3, 0.1, 0.04), pin.SE3(np.eye(3), np.array([0.1, 0, 0])))
    spheres = primitive_spheres(box)
    centres = np.array([c for c, _ in spheres])
    radius = spheres[0][1]
    # a row along x inside the box, covering its length and its cross-section's half width
    assert len(spheres) == 3 and np.allclose(centres[:, 1:], 0)
    assert centres[:, 0].min() - radius <= -0.05 + 1e-12 and centres[:, 0].max() + radius >= 0.25 - 1e-12
    assert radius >= 0.05 - 1e-12
    plate = Primitive("box", (0.448, 0.219, 0.053), pin.SE3.Identity())        # Solo12's base, as its mesh's box
    spheres = primitive_spheres(plate)
    centres, radii = np.array([c for c, _ in spheres]), np.array([r for _, r in spheres])
    assert len(spheres) == 6 and len(set(np.round(centres[:, 1], 6))) == 2    # two rows along the plate
    assert (centres[:, 0] - radii).min() <= -0.224 + 1e-12 and (centres[:, 1] + radii).max() >= 0.1095 - 1e-12
    assert radii.max() - 0.0265 < 0.05                                          # not far below the plate
    cylinder = Primitive("cylinder", (0.01, 0.138), pin.SE3(pin.rpy.rpyToMatrix(0, math.pi / 2, 0), np.zeros(3)))
    along = np.array([c for c, _ in primitive_spheres(cylinder)])
    assert len(along) == 3 and np.allclose(along[:, 1:], 0, atol=1e-12)   # the cylinder's axis is x here


def test_joint_axes_of_scarab(scarab2):
    origins, axes = joint_axes(scarab2, scarab2.q_nominal)
    assert origins.shape == axes.shape == (18, 3)
    np.testing.assert_allclose(np.abs(axes[0::3, 2]), 1.0, atol=1e-9)      # coxa: vertical
    np.testing.assert_allclose(axes[1::3, 2], 0.0, atol=1e-9)              # femur, tibia: horizontal
    np.testing.assert_allclose(axes[2::3, 2], 0.0, atol=1e-9)
    # a positive femur rotation lifts the foot (robot.yaml's convention for SCARAB II)
    q = scarab2.q_nominal.copy()
    q[7 + 1] += 0.05
    assert scarab2.foot_positions(q)[0, 0, 2] > 0.0
