"""The base-above-feet rows (`BaseAboveFeetBlock`): on by default, held leg by leg at the samples
the independent check judges, measured at the base frame's origin as the check measures it."""

from dataclasses import replace

import numpy as np
import pytest

from legplan.dyn.constraints import BaseAboveFeetBlock
from legplan.dyn.euler import rotation
from legplan.dyn.init import heuristic
from legplan.dyn.planner import sample_solution
from legplan.dyn.problem import DynParams, DynTask, build_problem
from legplan.solve import check_jacobian

TASK = DynTask((-0.3, 0.1, 0.2), (0.9, 0.0, 0.0), "walk", 2, 3.0)


def _perturbed(problem, seed=3, scale=0.02):
    rng = np.random.default_rng(seed)
    return {b.name: b.value + scale * rng.standard_normal(b.size) for b in problem.variables}


def test_every_plan_sample_inside_a_swing_has_its_base_above_foot_row(anymal, step):
    """A swing foot rises fastest: the check judges base z − the highest foot z at every plan sample
    (`SAMPLE_DT`), so a leg's rows hold at each of its samples inside its swings, with the value the
    sampled plan has there."""
    problem = build_problem(TASK, anymal, step, DynParams(), heuristic)
    rows = [k for k in problem.constraints if k.name == "base_clearance"]
    assert len(rows) == problem.form.legs and all(k.lower[0] == DynParams().base_clearance for k in rows)
    values = _perturbed(problem)
    samples = sample_solution(problem.form, values)
    gap = samples["base_pos"][:, 2, None] - samples["feet_pos"][..., 2]  # (samples, legs)
    for leg, k in enumerate(rows):
        r, _ = k.block.evaluate([values[v] for v in k.block.variables], False)
        swinging = ~samples["contact"][:, leg].astype(bool)
        assert swinging.sum() > 10
        for value in gap[swinging, leg]:
            assert np.min(np.abs(r - value)) < 1e-12


@pytest.mark.parametrize("optimize_phases", [False, True], ids=["fixed_timing", "optimize_phases"])
def test_rows_with_a_com_offset_measure_the_base_origin_and_match_finite_differences(anymal, step, optimize_phases):
    """With the CoM off the base origin the row is c_z − (R(e) o)_z − p_i,z: equal to the sampled base
    origin's height above the foot, and its Jacobian (∂R/∂e included) equals finite differences."""
    offset = np.array([0.05, -0.02, 0.03])
    model = replace(anymal, com_offset=offset)
    problem = build_problem(TASK, model, step, replace(DynParams(), optimize_phases=optimize_phases), heuristic)
    values = _perturbed(problem)
    rows = [k for k in problem.constraints if k.name == "base_clearance"]
    for k in rows:
        assert "base_ang" in k.block.variables
        report = check_jacobian(k.block, {v: values[v] for v in k.block.variables})
        assert report.ok(atol=1e-6, rtol=1e-5), report
    block = BaseAboveFeetBlock(problem.form, 0, np.array([0.5, 1.0]), None, offset)
    r, _ = block.evaluate([values[v] for v in block.variables], False)
    c = problem.form.base_matrix([0.5, 1.0]) @ values["base_lin"].reshape(-1, 3)
    e = problem.form.base_matrix([0.5, 1.0]) @ values["base_ang"].reshape(-1, 3)
    foot = problem.form.foot_matrix(0, [0.5, 1.0]) @ values["feet"].reshape(-1, 3)
    origin = c - rotation(e) @ offset
    np.testing.assert_allclose(r, origin[:, 2] - foot[:, 2], atol=1e-12)


def test_switched_off_it_adds_no_rows(anymal, flat):
    problem = build_problem(TASK, anymal, flat, replace(DynParams(), base_clearance=None), heuristic)
    assert "base_clearance" not in {k.name for k in problem.constraints}
