"""leg_reach: batch per-foot IK inside the planning limits, for any base pose and any leg chain."""


import numpy as np
import pytest
from robot_helpers import random_configurations

from legplan.robots.legik import leg_reach
from legplan.robots.so3 import rotvec_to_matrix


@pytest.mark.parametrize("name", ["anymal", "jueying", "toy"])
def test_feet_of_random_configurations_are_reachable(name, request):
    """Targets = feet of random configurations (any base pose, joints inside the limits): reachable,
    and the joints found put the feet there (FK of the full configuration)."""
    robot = request.getfixturevalue(name)
    Q = random_configurations(robot, np.random.default_rng(30), 200)
    X = robot.to_vector(Q)
    base_pos, base_rot = X[:, :3], rotvec_to_matrix(X[:, 3:6])
    feet = robot.foot_positions(Q).copy()
    result = leg_reach(robot, base_pos, base_rot, feet)
    assert result.reachable.all(), (result.error.max(), np.argwhere(~result.reachable)[:5])
    assert np.all((result.joints >= robot.lower) & (result.joints <= robot.upper))
    assert np.all(result.limit_margin >= 0)
    solved = Q.copy()
    solved[:, 7:] = result.joints
    np.testing.assert_allclose(robot.foot_positions(solved), feet, atol=1e-6)


def test_target_reachable_only_outside_the_limits_is_unreachable(anymal):
    """haa at 0.8 rad (inside the URDF range, outside the planning limit 0.6) places a foot no joint
    solution inside the planning limits reaches; the error is the gap to the nearest one."""
    q = anymal.q_nominal.copy()
    q[anymal.legs[0].joint_idx_q[0]] = 0.8
    feet = anymal.foot_positions(q).copy()
    result = leg_reach(anymal, q[None, :3], np.eye(3)[None], feet)
    assert result.reachable[0].tolist() == [False, True, True, True]
    assert result.error[0, 0] > 0.02
    assert result.joints[0, anymal.legs[0].joint_idx[0]] == pytest.approx(0.6)       # held on the limit


def test_500_samples_of_4_legs_in_one_batch(anymal):
    """The batch API on 500 random poses inside the range of motion (its speed is bench/robot_kinematics.py's)."""
    rng = np.random.default_rng(31)
    c, n = anymal.centroidal, 500
    base_pos = np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(0.35, 0.5, n)])
    base_rot = rotvec_to_matrix(rng.uniform(-0.3, 0.3, (n, 3)))
    local = c.nominal_feet + rng.uniform(-1, 1, (n, 4, 3)) * c.range_of_motion
    feet = base_pos[:, None] + np.einsum("nij,nlj->nli", base_rot, local)
    result = leg_reach(anymal, base_pos, base_rot, feet)
    assert result.reachable.all() and result.error.shape == (n, 4) and result.joints.shape == (n, 12)
    assert result.error.max() < 1e-6


def test_bad_shapes(anymal):
    with pytest.raises(ValueError, match="feet_world"):
        leg_reach(anymal, np.zeros((2, 3)), np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3, 3)))
