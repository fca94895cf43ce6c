"""The independent check of centroidal trajectories: known answers on hand-built samples, planted
violations caught, and a real flat-ground solve."""

import dataclasses

import numpy as np
import pytest

from legplan.robots import load_robot
from legplan.terrain import Grid2D, terrain_from_heightmap
from legplan.validate import CentroidalCheck, check_trajectory
from legplan.validate.trajectory import GRAVITY, MINIMA, SPHERE_REACH, UNITS, CheckTolerances

N = 21  # samples 0, 0.01, ..., 0.2 s: nodes at 0, 0.1, 0.2


@pytest.fixture(scope="module")
def anymal():
    return load_robot("anymal")


@pytest.fixture(scope="module")
def model(anymal):
    return anymal.centroidal


def _rz(a):
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _ry(a):
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _rx(a):
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def _rot(e):
    return _rz(e[2]) @ _ry(e[1]) @ _rx(e[0])


def _stance(model, height=0.42):
    """Standing still in the nominal stance on z = 0, each foot carrying m g / 4."""
    zeros = np.zeros((N, 3))
    feet = np.tile(model.nominal_feet + [0.0, 0.0, height], (N, 1, 1))
    forces = np.zeros((N, 4, 3))
    forces[..., 2] = model.mass * GRAVITY / 4
    return {"t": np.linspace(0.0, 0.2, N), "base_pos": np.tile([0.0, 0.0, height], (N, 1)), "base_vel": zeros.copy(),
            "base_acc": zeros.copy(), "base_euler": zeros.copy(), "base_euler_rate": zeros.copy(),
            "base_ang_vel": zeros.copy(), "base_ang_acc": zeros.copy(), "feet_pos": feet,
            "feet_vel": np.zeros((N, 4, 3)), "forces": forces, "contact": np.ones((N, 4), bool)}


def _check(samples, model, terrain, robot, **kw):
    return check_trajectory(samples, model, terrain, robot, **kw)


def _failed(check: CentroidalCheck) -> set[str]:
    return {name for name, ok in check.passed.items() if not ok}


def test_static_stance_has_no_residual_and_passes(model, flat_terrain, anymal):
    check = _check(_stance(model), model, flat_terrain, anymal)
    assert check.worst["newton_euler_force"] < 1e-9 and check.worst["newton_euler_torque"] < 1e-9
    assert check.ok, check.worst
    assert check.worst["base_height"] == pytest.approx(0.42)
    assert check.worst["base_above_feet"] == pytest.approx(0.42)
    # trunk spheres r = 0.13 at z = 0.42: clear by more than the resolved reach
    assert check.worst["trunk_penetration"] == pytest.approx(-SPHERE_REACH)
    assert check.worst["leg_reach"] < 1e-4 and check.worst["joint_limit_margin"] > 0.2
    assert set(check.worst) == set(UNITS) == set(check.passed) == set(check.tolerance)  # every metric judged


def test_failures_name_metric_value_and_bound(model, flat_terrain, anymal):
    """`failures` lists each failed metric with its worst value and its bound, lower bounds with '<'."""
    s = _stance(model)
    s["base_pos"][3, 2] = -0.05                               # the base under the ground and the feet
    check = _check(s, model, flat_terrain, anymal)
    failed = check.failures()
    assert "base_above_feet -0.05 < 0 m" in failed and "trunk_penetration 0.18 > 0.005 m" in failed, failed
    assert {f.split()[0] for f in failed} == _failed(check) and "base_height" in _failed(check)
    assert set(MINIMA) <= set(check.tolerance)


def test_com_offset_moves_the_centre_of_the_dynamics(model, flat_terrain, anymal):
    """With the CoM 5 cm ahead of the base origin, the stance forces of the origin-centred model leave
    a pitch torque m g · 0.05 about the CoM; forces shifted to balance about the CoM remove it. A base
    turning at ω about z gives the CoM a centripetal acceleration −ω² (R o) the check adds to p̈."""
    ahead = dataclasses.replace(model, com_offset=np.array([0.05, 0.0, 0.0]))
    s = _stance(model)
    assert _check(s, ahead, flat_terrain, anymal).worst["newton_euler_torque"] == pytest.approx(
        model.mass * GRAVITY * 0.05, rel=1e-9)
    weight = model.mass * GRAVITY
    front = weight * (0.05 + 0.34) / 0.68 / 2                 # moments about x = 0.05 balance
    s["forces"][:, :2, 2], s["forces"][:, 2:, 2] = front, weight / 2 - front
    balanced = _check(s, ahead, flat_terrain, anymal)
    assert balanced.worst["newton_euler_torque"] < 1e-9 and balanced.worst["newton_euler_force"] < 1e-9
    spin = 2.0
    s["base_ang_vel"][:] = [0.0, 0.0, spin]
    s["base_euler_rate"][:] = [0.0, 0.0, spin]
    assert _check(s, ahead, flat_terrain, anymal).worst["newton_euler_force"] == pytest.approx(
        model.mass * spin ** 2 * 0.05, rel=1e-9)


def test_leg_penetration_is_judged_in_every_check(model, flat_terrain, anymal):
    """Standing nominally on flat ground the legs' spheres are where pinocchio puts them at the
    nominal joints (the stance's IK solution); a 25 cm plateau under the knees (the feet beside it)
    reaches into the shank spheres: the whole-body check fails."""
    Q = anymal.q_nominal.copy()
    Q[:3] = [0.0, 0.0, 0.42]
    legs = np.flatnonzero((np.asarray(anymal.spheres.leg_index) >= 0) & ~np.asarray(anymal.spheres.is_foot, bool))
    centres = anymal.sphere_centres(Q)[0, legs]
    expected = float(np.max(anymal.spheres.radii[legs] - centres[:, 2]))
    check = _check(_stance(model), model, flat_terrain, anymal)
    assert check.worst["leg_penetration"] == pytest.approx(expected, abs=1e-4) and expected < -0.05
    assert check.passed["leg_penetration"] and check.ok
    grid = Grid2D(origin=(-0.6, -0.5), resolution=0.01, shape=(101, 121))
    x, _ = grid.centres()
    plateau = terrain_from_heightmap(np.where(np.abs(x) < 0.2, 0.25, 0.0), grid, name="plateau")
    low = centres[:, 2] - anymal.spheres.radii[legs]
    assert np.any((np.abs(centres[:, 0]) < 0.19) & (low < 0.25))  # some leg sphere reaches below the top
    into = _check(_stance(model), model, plateau, anymal)
    assert into.worst["leg_penetration"] > 0.01 and _failed(into) == {"leg_penetration"}


def _limited_anymal(tmp_path, limits):
    """A copy of the shipped anymal whose robot.yaml names `limits` (N m, each leg's three joints)."""
    import shutil

    import yaml

    from legplan.robots import shipped_robots_dir

    folder = tmp_path / "anymal_limited"
    shutil.copytree(shipped_robots_dir() / "anymal", folder)
    spec = yaml.safe_load((folder / "robot.yaml").read_text())
    spec["centroidal"]["torque_limits"] = {leg: list(limits) for leg in spec["centroidal"]["nominal_feet"]}
    (folder / "robot.yaml").write_text(yaml.safe_dump(spec))
    return load_robot(folder / "robot.yaml")


def test_joint_torques_are_judged_against_the_robots_limits_whatever_model_planned(model, flat_terrain, anymal,
                                                                                    tmp_path):
    """Standing nominally, each foot's m g / 4 needs τ = Jᵀ f at the nominal joints (pinocchio's
    Jacobian, independently here): the judged ratio to the shipped anymal's URDF efforts of 40 N m
    (its robot.yaml names no torque limits), with the bound 1.001 written beside it. The same
    stance with the feet pushing 3× harder sideways-inwards (balanced, so Newton–Euler still holds)
    needs more torque than the joints have: the check fails on joint_torque alone (within the
    friction cone and the normal-force bound, only the limits catch it), for TOWR's scalar model
    (no torque limits in the model that planned it) as for a model with them. A robot.yaml's own
    `torque_limits`, lower than the efforts, are the bound instead."""
    import pinocchio as pin

    q = anymal.q_nominal.copy()
    q[:3] = [0.0, 0.0, 0.42]
    data = anymal.model.createData()
    efforts = np.asarray(anymal.model.effortLimit, float)
    f = np.array([0.0, 0.0, model.mass * GRAVITY / 4])
    expected = 0.0
    for leg in anymal.legs:
        jac = pin.computeFrameJacobian(anymal.model, data, q, leg.foot_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
        cols = list(leg.joint_idx_v)
        assert np.all(efforts[cols] == 40.0)
        expected = max(expected, float(np.max(np.abs(jac[:, cols].T @ f) / efforts[cols])))
    assert model.torque_limits is None
    check = _check(_stance(model), model, flat_terrain, anymal)
    assert check.worst["joint_torque"] == pytest.approx(expected, rel=1e-6) and 0.1 < expected < 1
    assert check.passed["joint_torque"] and check.tolerance["joint_torque"] == pytest.approx(1.001)
    assert check.as_dict()["joint_torque_tolerance"] == pytest.approx(1.001)
    s = _stance(model)
    s["forces"][..., 2] *= 3.0                               # 3 m g down on the ground ...
    s["forces"][..., 1] = -np.sign(model.nominal_feet[:, 1]) * 0.3 * s["forces"][..., 2]   # ... inwards
    s["base_acc"][:, 2] = 2.0 * GRAVITY                      # ... lifting the body at 2 g
    scalar = _check(s, dataclasses.replace(model, max_normal_force=1e4), flat_terrain, anymal)
    assert scalar.worst["joint_torque"] > 1.001 and _failed(scalar) == {"joint_torque"}, scalar.failures()
    assert scalar.failures() == [f"joint_torque {scalar.worst['joint_torque']:.4g} > 1.001"]   # a ratio: no unit
    limited = dataclasses.replace(model, max_normal_force=1e4, torque_limits=tuple(np.full(3, 40.0) for _ in model.legs))
    heavy = _check(s, limited, flat_terrain, anymal)
    assert heavy.worst["joint_torque"] == scalar.worst["joint_torque"] and _failed(heavy) == {"joint_torque"}
    half = _limited_anymal(tmp_path, (20.0, 20.0, 20.0))
    halved = _check(_stance(model), model, flat_terrain, half)
    assert halved.worst["joint_torque"] == pytest.approx(2 * expected, rel=1e-6)
    assert halved.tolerance["joint_torque"] == pytest.approx(1.001)


def test_constant_acceleration_known_residuals(model, flat_terrain, anymal):
    """Feet forces m (a + g e_z) / 4 balance the linear row; their lever below the CoM leaves the
    pitch torque (Σ r_i) × f = 0.42 m a_x about y, which a matching ω̇ = I_W⁻¹ τ removes."""
    s = _stance(model)
    a = np.array([1.0, 0.0, 0.5])
    s["base_acc"][:] = a
    s["forces"][:] = model.mass * (a + [0.0, 0.0, GRAVITY]) / 4
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["newton_euler_force"] < 1e-9
    assert check.worst["newton_euler_torque"] == pytest.approx(0.42 * model.mass * a[0], rel=1e-12)
    torque = np.cross(model.nominal_feet, s["forces"][0]).sum(axis=0)
    s["base_ang_acc"][:] = np.linalg.solve(model.inertia, torque)   # R = I at zero Euler angles
    assert _check(s, model, flat_terrain, anymal).worst["newton_euler_torque"] < 1e-9


def test_rotating_body_torque_free_motion(model, flat_terrain, anymal):
    """A tumbling body in free fall: ω̇ = −I_W⁻¹ (ω × I_W ω), I_W = R I_B Rᵀ with R = Rz Ry Rx built
    here by hand, and the Euler rates whose ω is the one given (Ṙ Rᵀ by central differences)."""
    s = _stance(model, height=0.9)
    e = np.array([0.3, -0.2, 0.7])
    omega = np.array([0.4, -1.1, 0.8])
    R = _rot(e)
    inertia = R @ model.inertia @ R.T
    # Euler rates giving omega: solve [ω]x = Ṙ Rᵀ column by column (R linear in ė for small steps)
    h = 1e-6
    columns = []
    for k in range(3):
        d = np.eye(3)[k] * h
        w = (_rot(e + d) - _rot(e - d)) @ R.T / (2 * h)
        columns.append([w[2, 1], w[0, 2], w[1, 0]])
    rates = np.linalg.solve(np.array(columns).T, omega)
    s["base_euler"][:], s["base_euler_rate"][:], s["base_ang_vel"][:] = e, rates, omega
    s["base_ang_acc"][:] = -np.linalg.solve(inertia, np.cross(omega, inertia @ omega))
    s["base_acc"][:] = [0.0, 0.0, -GRAVITY]
    s["forces"][:] = 0.0
    s["contact"][:] = False
    s["feet_pos"][:] = s["base_pos"][0] + model.nominal_feet @ R.T
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["newton_euler_force"] < 1e-9
    assert check.worst["newton_euler_torque"] < 1e-9
    assert check.worst["angular_velocity"] < 1e-8
    assert check.worst["range_of_motion"] < 1e-12            # feet rigid with the base at nominal
    s["base_ang_acc"][:] = 0.0
    gyro = np.abs(np.cross(omega, inertia @ omega)).max()
    flying = _check(s, model, flat_terrain, anymal)  # no foot in contact: judged at every sample all the same
    assert flying.worst["newton_euler_torque"] == pytest.approx(gyro, rel=1e-12)
    s["base_ang_vel"][:] = R.T @ omega                       # body rates mistaken for world rates
    assert "angular_velocity" in _failed(_check(s, model, flat_terrain, anymal))


def test_wrong_base_acceleration_fails_newton_euler_at_the_nodes(model, flat_terrain, anymal):
    s = _stance(model)
    s["base_acc"][:, 0] = 0.5
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["newton_euler_force_nodes"] == pytest.approx(0.5 * model.mass)
    assert _failed(check) == {"newton_euler_force_nodes", "newton_euler_force"}


def test_residual_between_nodes_is_judged_by_the_looser_bound(model, flat_terrain, anymal):
    """Between the nodes the residual is judged against `between`·m·g (5 %), at the nodes against
    `newton_euler`·m·g: 0.5 m/s² (5.1 % of g) off between the nodes fails only the first, 0.4 m/s²
    neither, and both at a node time."""
    s = _stance(model)
    s["base_acc"][5, 0] = 0.5                                 # t = 0.05 s, between the nodes 0 and 0.1 s
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["newton_euler_force"] == pytest.approx(0.5 * model.mass)
    assert check.worst["newton_euler_force_nodes"] < 1e-9 and _failed(check) == {"newton_euler_force"}
    assert check.tolerance["newton_euler_force"] == pytest.approx(0.05 * model.mass * GRAVITY)
    s["base_acc"][5, 0] = 0.4
    assert _check(s, model, flat_terrain, anymal).ok
    assert _failed(_check(s, model, flat_terrain, anymal, node_times=[0.05])) == {"newton_euler_force_nodes"}


def test_foot_pushed_into_the_terrain(model, flat_terrain, anymal):
    s = _stance(model)
    s["feet_pos"][8:12, 1, 2] = -0.02                         # stance foot 2 cm deep for 40 ms
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["penetration_height"] == pytest.approx(0.02)
    assert check.worst["penetration_column"] == pytest.approx(0.02, abs=1e-9)
    assert check.worst["stance_height"] == pytest.approx(0.02)
    assert check.worst["stance_column"] == pytest.approx(0.02, abs=1e-9)
    assert {"penetration_height", "penetration_column", "stance_height", "stance_column", "stance_slip"} == _failed(check)


def test_swing_foot_into_a_block(model, step_terrain, anymal):
    """A swing foot passing 2 cm inside the 4 cm block of x > 0.3 (the front feet stand at x = 0.34,
    so the stance is lifted onto the block)."""
    s = _stance(model, height=0.46)
    s["feet_pos"][:, :2, 2] = 0.04
    s["contact"][:, 0] = False
    s["forces"][:, 0] = 0.0
    s["forces"][:, 1:, 2] = model.mass * GRAVITY / 3
    s["feet_pos"][:, 0, 2] = 0.02
    check = _check(s, model, step_terrain, anymal)
    assert check.worst["penetration_height"] == pytest.approx(0.02)
    assert check.worst["penetration_column"] == pytest.approx(0.02, abs=1e-9)
    assert {"penetration_height", "penetration_column"} <= _failed(check)


def test_force_outside_the_coulomb_cone(model, flat_terrain, anymal):
    """The cone, not TOWR's pyramid, is judged: a force inside the pyramid but outside the cone fails."""
    s = _stance(model)
    fn = model.mass * GRAVITY / 4
    s["forces"][3, 2] = [0.6 * fn, 0.0, fn]                   # |f·t1| = 0.6 f_n > μ f_n = 0.5 f_n
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["friction_cone"] == pytest.approx(0.1)
    assert "friction_cone" in _failed(check)
    s["forces"][3, 2] = [0.45 * fn, 0.45 * fn, fn]            # inside the pyramid, outside the cone
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["friction_cone"] == pytest.approx(0.45 * np.sqrt(2) - 0.5)
    assert "friction_cone" in _failed(check)
    s["forces"][3, 2] = [0.35 * fn, 0.35 * fn, fn]            # inside the cone
    assert _check(s, model, flat_terrain, anymal).passed["friction_cone"]


def test_normal_force_bounds(model, flat_terrain, anymal):
    s = _stance(model)
    s["forces"][2, 0] = [0.0, 0.0, -10.0]                     # pulling on the ground
    s["forces"][4, 1] = [0.0, 0.0, 1100.0]                    # above f_max = 1000 N
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["normal_force"] == pytest.approx(max(10.0 / (model.mass * GRAVITY / 4), 100.0 / 1100.0))
    assert "normal_force" in _failed(check)


def test_friction_uses_the_terrain_normal_on_a_slope():
    """On h = 0.2 x, a force μ f_n along t1 ∝ (1, 0, 0.2) on top of f_n along n ∝ (−0.2, 0, 1) sits
    on the cone; 0.1 f_n more along t1 violates it by 0.1 relative."""
    robot = load_robot("anymal")
    model = robot.centroidal
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 101))
    x, _ = grid.centres()
    slope = terrain_from_heightmap(0.2 * x, grid, name="slope")
    s = _stance(model)
    s["feet_pos"][..., 2] = 0.2 * s["feet_pos"][..., 0]
    n = np.array([-0.2, 0.0, 1.0]) / np.sqrt(1.04)
    t1 = np.array([1.0, 0.0, 0.2]) / np.sqrt(1.04)
    fn = 200.0
    s["forces"][:] = fn * n + 0.5 * fn * t1
    assert _check(s, model, slope, robot).worst["friction_cone"] < 1e-9
    s["forces"][:] = fn * n + 0.6 * fn * t1
    assert _check(s, model, slope, robot).worst["friction_cone"] == pytest.approx(0.1, rel=1e-6)


def test_swing_foot_with_force(model, flat_terrain, anymal):
    s = _stance(model)
    s["contact"][10:, 0] = False
    s["forces"][10:, 0] = 0.0
    s["forces"][12, 0] = [0.0, 3.0, 4.0]
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["swing_force"] == pytest.approx(5.0 / (model.mass * GRAVITY / 4))
    assert "swing_force" in _failed(check)


def test_stance_foot_slip_per_contact_phase(model, flat_terrain, anymal):
    s = _stance(model)
    s["contact"][8:12, 2] = False                             # leg lh: stance, swing, stance again
    s["forces"][8:12, 2] = 0.0
    s["feet_pos"][8:, 2, 0] += 0.05                           # it lands 5 cm further: no slip
    s["feet_pos"][15:, 2, 0] += 0.01                          # then slides 1 cm in its second stance
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["stance_slip"] == pytest.approx(0.01)
    assert "stance_slip" in _failed(check)


def test_foot_outside_the_box_and_out_of_reach(model, flat_terrain, anymal):
    s = _stance(model)
    s["contact"][:, 0] = False
    s["forces"][:, 0] = 0.0
    s["forces"][:, 1:, 2] = model.mass * GRAVITY / 3
    s["feet_pos"][6, 0, 0] += 0.5                             # lf 0.5 m ahead: box 0.15 m, legs 0.61 m
    check = _check(s, model, flat_terrain, anymal)
    assert check.worst["range_of_motion"] == pytest.approx(0.5 - model.range_of_motion[0])
    assert check.worst["leg_reach"] > 0.02
    assert {"range_of_motion", "leg_reach"} <= _failed(check)


def test_legs_matched_to_the_robot_by_name(model, flat_terrain, anymal):
    """A centroidal model listing the legs in another order, with samples in that order, checks the
    same: the unreachable foot is found on the robot's lf leg whichever column it is in."""
    s = _stance(model)
    s["feet_pos"][6, 0, 0] += 0.5
    order = [3, 0, 2, 1]
    shuffled = dataclasses.replace(model, legs=tuple(model.legs[k] for k in order),
                                   nominal_feet=model.nominal_feet[order].copy())
    t = {k: (v[:, order] if k in ("feet_pos", "feet_vel", "forces", "contact") else v) for k, v in s.items()}
    a, b = _check(s, model, flat_terrain, anymal), _check(t, shuffled, flat_terrain, anymal)
    assert a.worst == pytest.approx(b.worst)


def test_as_dict_is_flat_scalars(model, flat_terrain, anymal):
    check = _check(_stance(model), model, flat_terrain, anymal)
    d = check.as_dict()
    assert d["passed"] is True and d["friction_cone_passed"] is True
    assert d["friction_cone_tolerance"] == 1e-3 and d["leg_penetration_passed"] is True
    assert all(isinstance(v, (float, bool)) for v in d.values())


def test_real_flat_walk_passes(anymal):
    """A real solve with the planner's defaults and its model of the robot (legplan.dyn only
    produces the input; the model keeps the joint torques inside the URDF's efforts): every metric
    holds, the Newton–Euler residual at every 10 ms sample and the joint torques included."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel

    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    terrain = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    model = centroidal_model(anymal, DynParams())
    result = plan(DynTask((0, 0, 0), (1.5, 0, 0), "walk", 4, 3.5), model, TerrainModel(terrain), DynParams())
    assert result.success, result.reason
    assert result.samples["t"].size == 351
    check = check_trajectory(result.samples, model, terrain, anymal, node_times=result.problem.form.knots)
    assert check.ok and not _failed(check), (_failed(check), check.worst)
    assert check.tolerance["joint_torque"] == pytest.approx(1.001) and check.worst["joint_torque"] <= 1.001
