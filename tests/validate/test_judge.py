"""Judging configurations and paths on every constraint: shortfalls against the stated requirements."""

import numpy as np
import pytest

from legplan.contact.terms import swing_foot_margin
from legplan.validate import Validator
from legplan.validate.judge import Requirements, failures, row_failures, shortfalls


def test_clearance_shortfall_is_requirement_minus_lowest_sphere_clearance(scarab, flat_terrain):
    validator = Validator(scarab, flat_terrain)
    Q = np.repeat(scarab.q_nominal[None], 2, axis=0)
    Q[1, 2] += 0.05
    stance = np.ones(scarab.n_legs, bool)
    feet = validator.kinematics(Q[:1])[0][0]
    per_row, checks = shortfalls(validator, Q, stance, feet, Requirements(clearance=0.02, tolerance=1e-6))
    non_foot = ~np.asarray(scarab.spheres.is_foot)
    centres = scarab.sphere_centres(Q)[:, non_foot]
    lowest = (centres[..., 2] - np.asarray(scarab.spheres.radii)[non_foot]).min(axis=1)
    np.testing.assert_allclose(per_row["clearance"], 0.02 - lowest - 1e-6, atol=1e-9)
    assert per_row["foot_slip"][0] == pytest.approx(-1e-3, abs=1e-9)  # feet on their footholds
    assert per_row["foot_slip"][1] == pytest.approx(0.05 - 1e-3, abs=1e-9)  # lifted 5 cm off them
    assert per_row["joint_limits"][0] == -1e-6 and per_row["com_margin"][0] < 0


def test_a_short_constraint_is_named_with_its_tolerance():
    required = Requirements(tolerance=1e-5)
    missed = failures({"foot_slip": -1e-4, "com_margin": -0.01, "clearance": 2.3e-3, "joint_limits": 0.0},
                      required)
    assert missed == ["clearance short by 2.3 mm beyond its tolerance 0.01 mm"]
    rows = row_failures({"clearance": np.array([-1.0, 1e-3]), "joint_limits": np.array([0.0, 0.0])}, required)
    assert rows == ["row 1: clearance short by 1 mm beyond its tolerance 0.01 mm"]


def test_swing_foot_ramp_relaxes_the_foot_near_the_path_ends(scarab, flat_terrain):
    """A swing foot sliding along the ground: allowed at the ends, short everywhere beyond the ramp."""
    validator = Validator(scarab, flat_terrain)
    stance = np.ones(scarab.n_legs, bool)
    stance[0] = False
    q = scarab.q_nominal.copy()
    path = np.repeat(q[None], 3, axis=0)
    feet = validator.kinematics(q[None])[0][0]
    required = Requirements(clearance=0.02, foot_clearance=0.02, relax_radius=0.05)
    per_row, _ = shortfalls(validator, path, stance, feet, required, path=True)
    # the foot sphere never leaves its end position: the ramp's floor −(r + ε) applies
    foot = np.flatnonzero(np.asarray(scarab.spheres.is_foot) & (np.asarray(scarab.spheres.leg_index) == 0))[0]
    radius = scarab.spheres.radii[foot]
    floor, _ = swing_foot_margin(0.0, radius, 0.02, 1e-3, 0.05)
    assert floor == pytest.approx(-(radius + 1e-3))
    assert np.all(per_row["clearance"] < 0)
    single, _ = shortfalls(validator, path[:1], stance, feet, required)  # no ramp outside a path
    assert single["clearance"][0] == pytest.approx(0.02 + radius - validator.surface.signed_distance(
        validator.kinematics(q[None])[1][0, foot:foot + 1])[0], abs=1e-9)
