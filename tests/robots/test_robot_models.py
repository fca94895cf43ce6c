"""The repository robots: dimensions, nominal stance, self-collision-free limits, navigation data."""

import numpy as np
import pytest

from legplan.geometry.polygon import support_polygon
from legplan.robots import list_robots, load_robot


def test_repository_robots_are_listed():
    assert {"scarab2", "jueying_mini", "anymal"} <= set(list_robots())


def test_scarab2_dimensions(scarab2):
    assert (scarab2.nq, scarab2.nv, scarab2.n_joints, scarab2.n_legs) == (25, 24, 18, 6)
    assert [leg.foot_frame for leg in scarab2.legs] == [f"foot_{n}" for n in ("lf", "lm", "lr", "rf", "rm", "rr")]
    assert all(len(leg.joint_names) == 3 for leg in scarab2.legs)
    # Leg joint indices address the same joints in q, v and the actuated-joint arrays.
    for leg in scarab2.legs:
        assert [scarab2.joint_names[k] for k in leg.joint_idx] == list(leg.joint_names)
        assert np.all(np.array(leg.joint_idx_q) == np.array(leg.joint_idx_v) + 1)
    # DH offsets: femur -0.3926 rad is horizontal, tibia +pi/2 in line with it; the straight middle
    # leg then points along +-y with the reach coxa + femur + tibia.
    Q = scarab2.q_nominal[None].copy()
    Q[0, 7:] = 0.0
    Q[0, [leg.joint_idx_q[1] for leg in scarab2.legs]] = -0.3926
    Q[0, [leg.joint_idx_q[2] for leg in scarab2.legs]] = np.pi / 2
    hip_to_foot = scarab2.foot_positions(Q)[0, 1] - np.array([0.0, 0.12, Q[0, 2]])
    np.testing.assert_allclose(hip_to_foot, [0.0, 0.026 + 0.093 + 0.122, 0.0], atol=1e-8)
    assert 2.0 < scarab2.mass < 3.0
    assert scarab2.navigation is None


@pytest.mark.parametrize("name", ["scarab2", "jueying", "anymal", "toy"])
def test_nominal_stance_feet_on_ground_com_inside(name, request):
    robot = request.getfixturevalue(name)
    q = robot.q_nominal
    assert np.all((q[7:] >= robot.lower) & (q[7:] <= robot.upper))
    feet = robot.foot_positions(q)[0]
    np.testing.assert_allclose(feet[:, 2], 0.0, atol=1e-3)
    com = robot.com(q)[0]
    assert support_polygon(feet).contains(com[None, :2], margin=0.05)[0]
    assert com[2] > 0.05
    # Only foot spheres may touch the ground in the stance.
    centres = robot.sphere_centres(q)[0]
    clearance = centres[:, 2] - robot.spheres.radii
    assert np.all(clearance[~robot.spheres.is_foot] > 0.02)


def test_scarab2_limits_avoid_self_collision_of_neighbouring_legs(scarab2):
    """Paper Sec. II-B: joint ranges avoid self-collision. Corners of the limit box and random joints."""
    robot = scarab2
    rng = np.random.default_rng(20)
    n = 3000
    corners = np.where(rng.integers(0, 2, (n // 2, robot.n_joints)).astype(bool), robot.upper, robot.lower)
    joints = np.concatenate([corners, rng.uniform(robot.lower, robot.upper, (n - n // 2, robot.n_joints))])
    Q = np.repeat(robot.q_nominal[None], n, axis=0)
    Q[:, 7:] = joints
    centres, radii, leg = robot.sphere_centres(Q), robot.spheres.radii, robot.spheres.leg_index
    names = [leg_.name for leg_ in robot.legs]
    for a, b in [("lf", "lm"), ("lm", "lr"), ("rf", "rm"), ("rm", "rr")]:
        ia, ib = np.flatnonzero(leg == names.index(a)), np.flatnonzero(leg == names.index(b))
        gap = (np.linalg.norm(centres[:, ia, None] - centres[:, None, ib], axis=-1)
               - radii[ia][:, None] - radii[ib][None])
        assert gap.min() > 0.0, (a, b, gap.min())


def test_scarab2_spheres_cover_body_femur_tibia_foot(scarab2):
    spheres = scarab2.spheres
    assert np.sum(spheres.leg_index == -1) >= 3
    for k, leg in enumerate(scarab2.legs):
        names = [spheres.frame_names[i] for i in np.flatnonzero(spheres.leg_index == k)]
        assert any(n.startswith("femur") for n in names) and any(n.startswith("tibia") for n in names)
        feet = np.flatnonzero((spheres.leg_index == k) & spheres.is_foot)
        assert len(feet) == 1 and spheres.frame_ids[feet[0]] == leg.foot_frame_id
    assert spheres.radii[spheres.is_foot].max() < spheres.radii[~spheres.is_foot].min()


def test_jueying_navigation_table_i(jueying):
    nav = jueying.navigation
    limits = nav.limits
    assert (limits.v_x_max, limits.v_x_min, limits.v_y_max, limits.omega_max) == (0.75, 0.10, 0.20, 0.70)
    assert (limits.a_x_max, limits.a_y_max, limits.alpha_max) == (1.00, 0.17, 0.52)
    assert nav.footprint.shape == (4, 2)
    assert nav.inscribed_radius == pytest.approx(0.20)
    assert nav.circumscribed_radius == pytest.approx(np.hypot(0.35, 0.20))
    assert (jueying.nq, jueying.nv, jueying.n_legs) == (19, 18, 4)


def test_load_by_folder_yaml_and_pickle(scarab2, tmp_path, monkeypatch):
    import pickle

    by_folder = load_robot(scarab2.yaml_path.parent)
    by_yaml = load_robot(scarab2.yaml_path)
    assert by_folder.nq == by_yaml.nq == 25
    clone = pickle.loads(pickle.dumps(scarab2))
    np.testing.assert_allclose(clone.foot_positions(scarab2.q_nominal), scarab2.foot_positions(scarab2.q_nominal))
    monkeypatch.setenv("LEGPLAN_ROBOTS", str(tmp_path))     # an empty folder in front of the shipped robots
    assert {"scarab2", "jueying_mini", "anymal"} <= set(list_robots())
