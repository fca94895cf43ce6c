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
