"""The `centroidal:` section of robot.yaml parsed into `Centroidal` (its bad values: test_robot_spec.py)."""

import copy

import numpy as np
import pytest
from robot_helpers import toy_centroidal, toy_spec, write_toy_robot

from legplan.errors import SpecError
from legplan.robots import load_robot


def test_section_parsed_in_leg_order(tmp_path):
    spec = copy.deepcopy(toy_spec())
    spec["centroidal"] = toy_centroidal()
    c = load_robot(write_toy_robot(tmp_path / "toy", spec), strict=False).centroidal   # parsing only
    assert c.mass == 4.6 and c.max_normal_force == 100.0 and c.friction == 0.6
    assert isinstance(c.max_normal_force, float)
    np.testing.assert_array_equal(c.inertia, [[0.05, 0.001, -0.002], [0.001, 0.12, 0.003], [-0.002, 0.003, 0.13]])
    assert c.legs == ("a", "b", "c", "d")                                    # robot.yaml's leg order
    np.testing.assert_array_equal(c.nominal_feet, [[0.2, 0.1, -0.26], [0.2, -0.1, -0.26],
                                                   [-0.2, 0.1, -0.25], [-0.2, -0.1, -0.26]])
    np.testing.assert_array_equal(c.range_of_motion, [0.05, 0.04, 0.03])
    assert c.base_height == pytest.approx(0.2575)
    with pytest.raises(ValueError):
        c.inertia[0, 0] = 1.0                                                # read-only arrays
    with pytest.raises(AttributeError):
        c.mass = 1.0                                                         # frozen


def test_torque_limits_above_the_urdf_efforts_or_of_the_wrong_length_are_refused(published_anymal_b, tmp_path):
    """torque_limits per leg: more bounds than the leg has joints is refused by the loader, a bound
    above its joint's URDF effort by the strict loader and reported by `robot check` per leg; a
    lower bound (a cautious user) is kept."""
    import yaml

    from legplan.robots.check import check_robot

    folder = tmp_path / "b"
    folder.mkdir()
    spec = yaml.safe_load(published_anymal_b.read_text())
    spec["urdf"] = str((published_anymal_b.parent / spec["urdf"]).resolve())
    path = folder / "robot.yaml"

    def written(limits):
        spec["centroidal"]["torque_limits"] = limits
        path.write_text(yaml.safe_dump(spec))
        return path

    legs = list(spec["centroidal"]["nominal_feet"])
    lower = load_robot(written({leg: [60, 70, 80] for leg in legs})).centroidal.torque_limits
    assert [list(v) for v in lower] == [[60, 70, 80]] * 4
    with pytest.raises(SpecError, match=r"field 'centroidal\.torque_limits\.LF' lists 4 bounds for the 3 joints"):
        load_robot(written({leg: [60, 70, 80, 90] if leg == "LF" else [60, 70, 80] for leg in legs}))
    with pytest.raises(SpecError, match=r"field 'centroidal\.torque_limits\.RH' exceeds the URDF's joint efforts "
                                        r"\(N m: RH_KFE 120 > 80\)"):
        load_robot(written({leg: [80, 80, 120] if leg == "RH" else [80, 80, 80] for leg in legs}))
    with pytest.raises(SpecError, match=r"field 'centroidal\.torque_limits\.XX' names no leg"):
        load_robot(written({**{leg: [80, 80, 80] for leg in legs}, "XX": [1, 2, 3]}))
    with pytest.raises(SpecError, match=r"field 'centroidal\.torque_limits\.LF\[1\]' must be > 0"):
        load_robot(written({leg: [80, 0, 80] for leg in legs}))
    robot = load_robot(written({leg: [80, 80, 120] if leg in ("LF", "RH") else [80, 80, 80] for leg in legs}),
                       strict=False)
    errors = [f.subject for f in check_robot(robot) if f.severity == "error"]
    assert errors == ["centroidal.torque_limits.LF", "centroidal.torque_limits.RH"]


def test_section_is_optional(toy, scarab2, jueying):
    assert toy.centroidal is None and scarab2.centroidal is None and jueying.centroidal is None


def test_a_section_that_contradicts_its_urdf_is_refused_naming_the_field(tmp_path):
    """The toy section's numbers are made up: loading holds them against the URDF (first field)."""
    spec = copy.deepcopy(toy_spec())
    spec["centroidal"] = toy_centroidal()
    path = write_toy_robot(tmp_path / "toy", spec)
    with pytest.raises(SpecError, match=r"robot\.yaml: field 'centroidal\.com_offset' is \(0\.000, 0\.000, 0\.000\) m "
                       r"but the URDF's CoM at the nominal stance is at"):
        load_robot(path)


def test_jueying_mini_dyn_is_the_navigation_robot_crouched_with_a_consistent_centroidal_model():
    """robots/jueying_mini_dyn: robots/jueying_mini's URDF, legs, planning limits and spheres in a lower
    stance, whose centroidal section `robot check` finds consistent with the URDF (no errors), and whose
    feet move in a box more than 3.8 cm high there (the navigation stance's, too little for a trot)."""
    from legplan.robots.check import check_robot
    from legplan.robots.rigid_body import composite_body, reach_box

    nav, dyn = load_robot("jueying_mini"), load_robot("jueying_mini_dyn")
    assert dyn.urdf_path.resolve() == nav.urdf_path.resolve() and nav.centroidal is None
    assert [leg.joint_names for leg in dyn.legs] == [leg.joint_names for leg in nav.legs]
    np.testing.assert_array_equal(dyn.lower, nav.lower)
    np.testing.assert_array_equal(dyn.upper, nav.upper)
    assert dyn.spheres.frame_names == nav.spheres.frame_names
    np.testing.assert_array_equal(dyn.spheres.radii, nav.spheres.radii)
    np.testing.assert_array_equal(dyn.spheres.offsets, nav.spheres.offsets)
    assert [f for f in check_robot(dyn) if f.severity == "error"] == []
    c = dyn.centroidal
    assert c.base_height < 0.26 < nav.q_nominal[2]
    np.testing.assert_allclose(c.range_of_motion, reach_box(dyn, c.nominal_feet), atol=1e-3)
    body = composite_body(nav.model, nav.q_nominal, [leg.foot_frame_id for leg in nav.legs])
    assert reach_box(nav, body.feet)[2] < 0.04 < c.range_of_motion[2]
