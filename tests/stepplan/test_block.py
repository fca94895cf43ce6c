"""The Bézier constraint block of eq. (12): analytic Jacobian vs finite differences, structured JᵀJ."""

import numpy as np
import pytest

from legplan.geometry.bezier import elevate
from legplan.solve import check_jacobian, check_normal_terms
from legplan.solve.curve import SampledCurveBlock
from legplan.stepplan.block import BezierConstraintBlock, SampleConstraints
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import contact_mode


def _block(toy_robot, swing_over_hill, degree=3, samples=12):
    hill, q0, q1, stance, feet = swing_over_hill
    ends = toy_robot.sphere_centres(np.stack([q0, q1]))
    sc = SampleConstraints(toy_robot, hill, contact_mode(stance, feet, StepPlanParams()), 1e-3,
                           swing_ends=ends, relax_radius=0.3)
    t = np.linspace(0, 1, samples + 1)[1:-1]
    rng = np.random.default_rng(4)
    P = elevate(np.stack([q0, q1]), degree - 1) + 0.02 * rng.normal(size=(degree + 1, 18))
    xi = 0.002 * rng.normal(size=len(t) * sc.slack_size)
    return BezierConstraintBlock(sc, degree, t), P, xi, sc


def test_rows_per_sample(toy_robot, swing_over_hill):
    block, P, xi, sc = _block(toy_robot, swing_over_hill)
    r, G, S = sc.evaluate(P[:2], np.zeros((2, sc.slack_size)), True)
    # 3 stance legs: 9 foot rows + 3 slack rows; triangle: 3 CoM rows; spheres: 1 swing foot + body;
    # 12 joints: 24 limit rows
    assert r.shape == (2, 9 + 3 + 3 + 2 + 24)
    assert G.shape == (2, r.shape[1], 18) and S.shape == (2, r.shape[1], 9)
    assert block.size == 11 * r.shape[1]


def test_jacobian_matches_finite_differences(toy_robot, swing_over_hill):
    block, P, xi, _ = _block(toy_robot, swing_over_hill)
    r, _ = block.evaluate([P.reshape(-1), xi], False)
    assert np.count_nonzero(r) > 20  # the check covers active constraints, not only zeros
    report = check_jacobian(block, [P.reshape(-1), xi])
    assert report.ok(atol=1e-5, rtol=1e-4), report


def test_structured_normal_terms_equal_jtj(toy_robot, swing_over_hill):
    block, P, xi, _ = _block(toy_robot, swing_over_hill)
    assert check_normal_terms(block, [P.reshape(-1), xi]) < 1e-9


def test_residual_chunks_cover_every_sample_once(toy_robot, swing_over_hill):
    """Trial points are judged from sample groups (`residual_chunks`): together they must be the
    residual of `evaluate`, each sample exactly once."""
    block, P, xi, _ = _block(toy_robot, swing_over_hill, samples=21)
    values = [P.reshape(-1), xi]
    r = block.evaluate(values, False)[0].reshape(block.samples, -1)
    chunks = [c.reshape(-1, r.shape[1]) for c in block.residual_chunks(values)]
    assert len(chunks) == 4 and sum(len(c) for c in chunks) == block.samples
    np.testing.assert_allclose(np.sort(np.concatenate(chunks), axis=0), np.sort(r, axis=0), rtol=0, atol=1e-15)
    assert sum(float(np.sum(c * c)) for c in chunks) == pytest.approx(float(np.sum(r * r)), rel=1e-13)


def test_trial_in_one_call_is_the_groups_of_the_sampled_curve(toy_robot, swing_over_hill):
    """The block evaluates a trial at every sample at once: its groups, in order, must be exactly those
    that `SampledCurveBlock.residual_chunks` forms group by group (so LM's decisions cannot change)."""
    block, P, xi, _ = _block(toy_robot, swing_over_hill, samples=21)
    values = [P.reshape(-1), xi]
    ours = list(block.residual_chunks(values))
    theirs = list(SampledCurveBlock.residual_chunks(block, values))
    assert len(ours) == len(theirs) == 4
    for a, b in zip(ours, theirs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_linearisation_at_the_trial_reuses_its_kinematics(toy_robot, swing_over_hill, monkeypatch):
    """After a trial at P the normal terms at P are those of a fresh evaluation, without a second
    kinematics pass; at other control points the kinematics are formed again."""
    block, P, xi, sc = _block(toy_robot, swing_over_hill, samples=21)
    values = [P.reshape(-1), xi]
    fresh = block.normal_terms(values)
    list(block.residual_chunks(values))
    calls = []
    points = sc.kinematics.points
    monkeypatch.setattr(sc.kinematics, "points", lambda X: calls.append(len(X)) or points(X))
    reused = block.normal_terms(values)
    assert calls == []
    np.testing.assert_array_equal(reused.residual, fresh.residual)
    for key, term in fresh.hessian.items():
        a, b = reused.hessian[key], term
        np.testing.assert_array_equal(getattr(a, "blocks", a), getattr(b, "blocks", b))
    for a, b in zip(reused.gradient, fresh.gradient, strict=True):
        np.testing.assert_array_equal(a, b)
    list(block.residual_chunks(values))
    calls.clear()
    block.normal_terms([values[0] + 1e-3, xi])
    assert calls == [block.samples]
