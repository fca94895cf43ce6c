"""The closed-form leg kinematics of the centroidal planner against pinocchio's, and its derivative."""

import numpy as np
from legplan.robots import leg_reach, load_robot
from legplan.robots.planar_legs import PlanarLegs


def _feet_in_range(robot, n, seed=0):
    """Feet (n, legs, 3) in the base frame, uniform in each leg's range-of-motion box (robot leg order)."""
    c = robot.centroidal
    order = [c.legs.index(leg.name) for leg in robot.legs]
    rng = np.random.default_rng(seed)
    return c.nominal_feet[order][None] + rng.uniform(-1.0, 1.0, (n, len(order), 3)) * c.range_of_motion


def test_thigh_and_shank_spheres_are_where_pinocchio_puts_them(anymal):
    """For 300 feet across the range-of-motion boxes: the spheres at pinocchio's FK of the numerical
    IK solution (`leg_reach`) and the closed form agree to the IK tolerance, every thigh and shank
    sphere of every leg."""
    legs = anymal.centroidal.leg_kinematics
    assert legs is not None and legs.sphere_index.size == 16  # 2 thigh + 2 shank spheres per leg
    n = 300
    feet = _feet_in_range(anymal, n)
    reach = leg_reach(anymal, np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), feet)
    assert reach.reachable.all()
    Q = np.zeros((n, anymal.nq))
    Q[:, 6], Q[:, 7:] = 1.0, reach.joints
    truth = anymal.sphere_centres(Q)
    for leg in range(anymal.n_legs):
        mine = legs.sphere_centres(leg, feet[:, leg])
        assert np.abs(mine - truth[:, legs.sphere_index[legs.spheres_of(leg)]]).max() < 1e-6


def test_closed_form_takes_complex_steps_exactly(anymal):
    """The complex step of the closed form equals its central difference (the planner's Jacobian)."""
    legs = anymal.centroidal.leg_kinematics
    feet = _feet_in_range(anymal, 20, seed=1)[:, 2]
    h, step = 1e-20, 1e-6
    for axis in range(3):
        direction = np.zeros(3)
        direction[axis] = 1.0
        complex_step = legs.sphere_centres(2, feet + 1j * h * direction).imag / h
        central = (legs.sphere_centres(2, feet + step * direction) - legs.sphere_centres(2, feet - step * direction)) / (2 * step)
        assert np.abs(complex_step - central).max() < 1e-6


def test_closed_form_jacobian_equals_the_complex_step_and_central_differences(anymal):
    """`sphere_centres_and_jacobian`: the centres of `sphere_centres` and ∂centre/∂foot equal to its
    complex step and to central differences, every leg, across and beyond the range-of-motion boxes
    (feet past full reach included, where b² is floored and the knee's offset stops moving)."""
    from legplan.dyn.euler import complex_step

    legs = anymal.centroidal.leg_kinematics
    feet = _feet_in_range(anymal, 400, seed=2)
    feet[200:] = feet[:200] + (feet[:200] - anymal.centroidal.nominal_feet[[anymal.centroidal.legs.index(leg.name)
                                                                           for leg in anymal.legs]][None])
    floored = 0
    for leg in range(anymal.n_legs):
        f = feet[:, leg]
        _, _, _, _, _, _, b2 = legs._plane(leg, f)
        floored += int((b2 <= 1e-9).sum())
        centres, jac = legs.sphere_centres_and_jacobian(leg, f)
        assert centres.shape == (len(f), legs.spheres_of(leg).size, 3) and jac.shape == centres.shape + (3,)
        np.testing.assert_allclose(centres, legs.sphere_centres(leg, f), rtol=0, atol=1e-14)
        value, (columns,) = complex_step(lambda x: legs.sphere_centres(leg, x).reshape(len(x), -1), (f,), (0,))
        np.testing.assert_allclose(jac, columns.reshape(jac.shape), rtol=0, atol=1e-9)
        step = 1e-6
        for axis in range(3):
            e = np.zeros(3)
            e[axis] = step
            central = (legs.sphere_centres(leg, f + e) - legs.sphere_centres(leg, f - e)) / (2 * step)
            # off full reach (b² ≥ 1e-4 m² on both sides), where the second derivative stays moderate
            inside = (legs._plane(leg, f + e)[-1] > 1e-4) & (legs._plane(leg, f - e)[-1] > 1e-4)
            assert inside.sum() > 100
            assert np.abs(jac[inside, :, :, axis] - central[inside]).max() < 1e-5
    assert floored > 0  # the floored branch is exercised


def test_legs_of_another_kind_have_no_closed_form():
    """scarab2's legs are no hip-abduction (x), hip and knee flexion (y) chains."""
    assert PlanarLegs.of_robot(load_robot("scarab2")) is None


def test_joints_of_published_legs_put_pinocchios_foot_there(published_robots, tmp_path):
    """HyQ (HAA axes along −x on its left legs) and Go1 as drafted from example-robot-data, spheres
    on the hips: the closed form of the joints alone applies (`spheres=False`), the sphere-placing
    one does not, and for joints across the planning limits the closed form gives them back from
    pinocchio's foot (the chain IK starts there, `ChainLegs.of_robot`)."""
    import pinocchio as pin

    from legplan.dyn.legs import ChainLegs
    from legplan.robots.draft import write_draft

    for name, urdf in (("hyq", "hyq_description/robots/hyq_no_sensors.urdf"), ("go1", "go1_description/urdf/go1.urdf")):
        path, _ = write_draft(published_robots / urdf, tmp_path / name)
        robot = load_robot(path)
        legs = PlanarLegs.of_robot(robot, spheres=False)
        assert PlanarLegs.of_robot(robot) is None and legs is not None and legs.sphere_index.size == 0
        assert all(c.closed_form is not None for c in ChainLegs.of_robot(robot).chains)
        model, data = robot.model, robot.model.createData()
        rng = np.random.default_rng(2)
        for k, leg in enumerate(robot.legs):
            ids = [model.idx_qs[model.getJointId(n)] for n in leg.joint_names]
            lower, upper = robot.lower[np.array(ids) - 7], robot.upper[np.array(ids) - 7]
            nominal = robot.q_nominal[ids]
            truth = np.clip(nominal + rng.uniform(-1.0, 1.0, (30, 3)) * [0.2, 0.3, 0.4], lower, upper)
            feet = []
            for joints in truth:
                q = robot.q_nominal.copy()
                q[:7], q[ids] = [0, 0, 0, 0, 0, 0, 1], joints
                pin.framesForwardKinematics(model, data, q)
                feet.append(data.oMf[leg.foot_frame_id].translation.copy())
            np.testing.assert_allclose(legs.joints(k, np.array(feet)), truth, atol=1e-10)
