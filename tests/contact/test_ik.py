import numpy as np

from legplan.contact import ContactMode, Posture, solve_ik
from legplan.validate import Validator


def test_ik_puts_stance_feet_on_footholds_with_com_margin_and_clearance(scarab, step_terrain):
    q0 = scarab.q_nominal.copy()
    feet = scarab.foot_positions(q0)[0]
    footholds = feet + np.array([0.03, 0.01, 0.0])
    stance = np.ones(scarab.n_legs, bool)
    support = stance.copy()
    support[0] = False  # CoM must also be inside the polygon without leg lf
    mode = ContactMode(stance=stance, footholds=footholds, support=support, com_margin=0.03, clearance=0.02)
    x_ref = scarab.to_vector(q0[None])[0]
    x0 = x_ref + np.random.default_rng(0).normal(scale=0.03, size=x_ref.shape)
    posture = Posture(x_ref, np.r_[np.zeros(2), 1.0, np.ones(3), np.full(scarab.n_joints, 0.05)])
    result = solve_ik(scarab, step_terrain.sdf, mode, x0, posture=posture)
    assert result.success, result.reason
    checks = Validator(scarab, step_terrain).check(result.q[None], stance[None], footholds[None])
    assert np.nanmax(checks.foot_slip) < 1e-4
    assert np.nanmax(np.abs(checks.foot_gap)) < 1e-4
    # the CoM is inside the 5-leg polygon with the margin, hence inside the 6-leg one even more
    assert checks.com_margin[0] >= 0.03 - 1e-6
    assert checks.clearance[0] >= 0.02 - 2e-3  # SDF vs exact surface differ by < a cell fraction
    assert checks.joint_excess.max() == 0.0


def test_ik_reports_an_unreachable_foot_target(scarab, flat_terrain):
    q0 = scarab.q_nominal.copy()
    feet = scarab.foot_positions(q0)[0]
    stance = np.ones(scarab.n_legs, bool)
    stance[0] = False
    mode = ContactMode(stance=stance, footholds=feet)
    x0 = scarab.to_vector(q0[None])[0]
    result = solve_ik(scarab, flat_terrain.sdf, mode, x0, targets={0: feet[0] + [1.0, 0.0, 0.0]})
    assert not result.success
    assert "foot error" in result.reason
