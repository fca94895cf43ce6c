"""robots/anymal: TOWR's ANYmal centroidal model (issue 14), legs that reach the whole range-of-motion box."""

import itertools

import numpy as np
import pinocchio as pin
import pytest

from legplan.robots.legik import leg_reach

# towr/include/towr/models/examples/anymal_model.h: SingleRigidBodyDynamics(29.5, Ixx, Iyy, Izz, Ixy,
# Ixz, Iyz) with products of inertia; BuildInertiaTensor puts their negatives off the diagonal.
TOWR_MASS = 29.5
TOWR_IXX, TOWR_IYY, TOWR_IZZ, TOWR_IXY, TOWR_IXZ, TOWR_IYZ = 0.946438, 1.94478, 2.01835, 0.000938112, -0.00595386, -0.00146328
TOWR_INERTIA = np.array([[TOWR_IXX, -TOWR_IXY, -TOWR_IXZ],
                         [-TOWR_IXY, TOWR_IYY, -TOWR_IYZ],
                         [-TOWR_IXZ, -TOWR_IYZ, TOWR_IZZ]])
TOWR_FEET = np.array([[0.34, 0.19, -0.42], [0.34, -0.19, -0.42], [-0.34, 0.19, -0.42], [-0.34, -0.19, -0.42]])
TOWR_ROM = np.array([0.15, 0.10, 0.10])


def test_loads_with_haa_hfe_kfe_legs(anymal):
    model = anymal.model
    assert (anymal.nq, anymal.nv, anymal.n_legs) == (19, 18, 4)
    assert [leg.name for leg in anymal.legs] == ["lf", "rf", "lh", "rh"]
    for leg in anymal.legs:
        assert leg.joint_names == (f"haa_{leg.name}", f"hfe_{leg.name}", f"kfe_{leg.name}")
        assert leg.foot_frame == f"foot_{leg.name}"
        kinds = [model.joints[model.getJointId(name)].shortname() for name in leg.joint_names]
        assert kinds == ["JointModelRX", "JointModelRY", "JointModelRY"]
    np.testing.assert_allclose(model.effortLimit[6:], 40.0)
    np.testing.assert_allclose(model.velocityLimit[6:], 8.0)
    assert np.all(anymal.lower > model.lowerPositionLimit[7:]) and np.all(anymal.upper < model.upperPositionLimit[7:])


def test_urdf_mass_and_link_inertias(anymal):
    model = anymal.model
    masses = [model.inertias[j].mass for j in range(1, model.njoints)]
    assert sum(masses) == pytest.approx(TOWR_MASS, abs=1e-9)
    assert pin.computeTotalMass(model) == pytest.approx(TOWR_MASS, abs=1e-9)
    for j in range(1, model.njoints):
        moments = np.linalg.eigvalsh(model.inertias[j].inertia)        # about the link's CoM
        assert masses[j - 1] > 0 and moments[0] > 0, model.names[j]
        assert moments[0] + moments[1] >= moments[2], model.names[j]  # triangle inequality


def test_centroidal_section_is_towr_anymal(anymal):
    c = anymal.centroidal
    assert c.mass == TOWR_MASS
    assert np.array_equal(c.inertia, TOWR_INERTIA)
    assert c.legs == ("lf", "rf", "lh", "rh")
    assert np.array_equal(c.nominal_feet, TOWR_FEET)
    assert np.array_equal(c.range_of_motion, TOWR_ROM)
    assert (c.max_normal_force, c.friction) == (1000.0, 0.5)
    assert c.base_height == pytest.approx(0.42, abs=1e-15)


def test_nominal_stance_is_towr_nominal_stance(anymal):
    """Pinocchio FK of q_nominal: base at 0.42 m, feet on (+-0.34, +-0.19, 0), i.e. TOWR's nominal
    feet in the base frame; whole-robot CoM at the base origin."""
    model, data, q = anymal.model, anymal.model.createData(), anymal.q_nominal
    assert q[2] == 0.42 and np.array_equal(q[3:7], [0, 0, 0, 1])
    pin.framesForwardKinematics(model, data, q)
    feet = np.array([data.oMf[model.getFrameId(f"foot_{leg}")].translation for leg in ("lf", "rf", "lh", "rh")])
    np.testing.assert_allclose(feet, TOWR_FEET + [0, 0, 0.42], atol=1e-9)
    np.testing.assert_allclose(pin.centerOfMass(model, data, q), [0, 0, 0.42], atol=1e-6)


def test_composite_inertia_in_nominal_stance_is_towr_inertia(anymal):
    """The URDF's whole-body inertia about the CoM in the nominal stance (pin.ccrba) = TOWR's I_b,
    so the single rigid body of `legplan dyn` is the URDF robot in that stance."""
    model, data = anymal.model, anymal.model.createData()
    pin.ccrba(model, data, anymal.q_nominal, np.zeros(model.nv))
    np.testing.assert_allclose(data.Ig.mass, TOWR_MASS, atol=1e-9)
    np.testing.assert_allclose(data.Ig.inertia, TOWR_INERTIA, atol=1e-6)


def _box_points(divisions: int) -> np.ndarray:
    """Points of the unit cube's surface on a (divisions + 1)^3 grid, corners included."""
    g = np.linspace(-1.0, 1.0, divisions + 1)
    return np.array([p for p in itertools.product(g, g, g) if np.abs(p).max() == 1.0])


def test_range_of_motion_box_is_reachable_within_limits(anymal):
    """Every corner and a face grid of the box around every nominal foot: IK error < 0.1 mm with all
    joints >= 0.25 rad inside their planning limits; the joints found put the feet on the targets
    under a tilted, shifted base too (pinocchio FK of the full configuration)."""
    c = anymal.centroidal
    corners = np.array(list(itertools.product([-1.0, 1.0], repeat=3)))
    offsets = np.vstack([corners, _box_points(6)]) * c.range_of_motion
    n = len(offsets)
    base_pos = np.tile([0.3, -0.2, 0.45], (n, 1))
    base_rot = np.tile(pin.rpy.rpyToMatrix(0.1, -0.15, 0.4), (n, 1, 1))
    feet = base_pos[:, None] + np.einsum("nij,nlj->nli", base_rot, c.nominal_feet[None] + offsets[:, None])
    result = leg_reach(anymal, base_pos, base_rot, feet)
    assert result.reachable.all()
    assert result.error.max() < 1e-6
    assert result.limit_margin.min() > 0.25
    Q = np.zeros((n, anymal.nq))
    Q[:, :3] = base_pos
    Q[:, 3:7] = pin.Quaternion(base_rot[0]).coeffs()
    Q[:, 7:] = result.joints
    np.testing.assert_allclose(anymal.foot_positions(Q), feet, atol=1e-6)


def _joint_grid_feet(robot, points: int) -> np.ndarray:
    """(points^3, n_legs, 3) world feet of every leg over a grid of its joints inside the planning
    limits, the base in its nominal pose."""
    Q = np.tile(robot.q_nominal, (points ** 3, 1))
    for leg in robot.legs:
        axes = [np.linspace(robot.lower[k], robot.upper[k], points) for k in leg.joint_idx]
        Q[:, 7 + np.array(leg.joint_idx)] = np.array(list(itertools.product(*axes)))
    return robot.foot_positions(Q)


def test_points_outside_the_box_are_unreachable(anymal):
    """0.3 m beyond each face of the box of every leg: reported unreachable, with an error no larger
    than the distance to the nearest foot of a joint grid (the IK found the closest point at least
    as well as brute force); 0.3 m below is beyond the stretched leg, so unreachable for certain."""
    c = anymal.centroidal
    directions = np.vstack([np.eye(3), -np.eye(3)])
    n = len(directions)
    feet = c.nominal_feet[None] + (directions * (c.range_of_motion + 0.3))[:, None] + [0.0, 0.0, 0.42]
    result = leg_reach(anymal, np.tile([0.0, 0.0, 0.42], (n, 1)), np.tile(np.eye(3), (n, 1, 1)), feet)
    assert not result.reachable.any()
    assert result.error.min() > 0.01
    grid = _joint_grid_feet(anymal, 21)                                           # base at (0, 0, 0.42)
    nearest = np.linalg.norm(grid[:, None] - feet[None], axis=-1).min(axis=0)      # (n, n_legs)
    assert np.all(result.error <= nearest + 1e-9)
    below = feet[directions[:, 2] == -1][0]
    hfe = np.array([0.34, 0.19 - 0.03, 0.42]) * [[1, 1, 1], [1, -1, 1], [-1, 1, 1], [-1, -1, 1]]
    assert np.all(np.linalg.norm(below - hfe, axis=1) > 0.28 + 0.33 + 0.03 + 0.1)
