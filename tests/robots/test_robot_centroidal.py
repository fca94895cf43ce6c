"""The `centroidal:` section of robot.yaml parsed into `Centroidal` (its bad values: test_robot_spec.py)."""

import copy

import numpy as np
import pytest
from robot_helpers import toy_centroidal, toy_spec, write_toy_robot

from legplan.robots import load_robot


def test_section_parsed_in_leg_order(tmp_path):
    spec = copy.deepcopy(toy_spec())
    spec["centroidal"] = toy_centroidal()
    c = load_robot(write_toy_robot(tmp_path / "toy", spec)).centroidal
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
