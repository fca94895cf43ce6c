"""Augmented Lagrangian over the hinged LM: equality and bound constraints, costs, stalls."""

import numpy as np
import pytest

from legplan.solve import FunctionBlock, VariableBlock
from legplan.solve.auglag import ALParams, Constraint, solve_augmented_lagrangian
from legplan.solve.blocks import LinearBlock


def _circle(x):  # x0² + x1² (one row)
    return np.array([x[0] ** 2 + x[1] ** 2]), [np.array([[2 * x[0], 2 * x[1]]])]


def test_cost_with_equality_constraint_reaches_the_kkt_point():
    # min (x0 − 2)² + (x1 − 1)²  s.t.  x0² + x1² = 1  →  x = (2, 1)/√5
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    k = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0, name="circle")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.5, 0.0])], [("target", cost, 1.0)], [k])
    assert r.success, r.reason
    assert r.values["x"] == pytest.approx(np.array([2.0, 1.0]) / np.sqrt(5), abs=2e-3)
    assert r.max_violation <= 1e-3
    assert r.violations["circle"] == r.max_violation


def test_bound_constraint_active_and_inactive():
    cost = LinearBlock(("x",), [np.eye(2)], np.array([3.0, -1.0]))
    box = Constraint(LinearBlock(("x",), [np.eye(2)]), [-np.inf, 0.0], [1.0, np.inf], name="box")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.0, 0.0])], [("target", cost, 2.0)], [box])
    assert r.success, r.reason
    assert r.values["x"] == pytest.approx([1.0, 0.0], abs=2e-3)  # both bounds active
    assert r.cost_terms["target"] == pytest.approx(0.5 * 2.0 * (4.0 + 1.0), rel=1e-2)


def test_feasibility_problem_without_costs_meets_the_tolerance_in_raw_units():
    # two circles: the scale weighs the rows, the tolerance stays in the block's units
    k1 = Constraint(FunctionBlock(("x",), 1, _circle), 4.0, 4.0, scale=1e-3)
    k2 = Constraint(LinearBlock(("x",), [np.array([[1.0, -1.0]])]), 0.0, np.inf, scale=10.0)  # x0 ≥ x1
    r = solve_augmented_lagrangian([VariableBlock("x", [3.0, 0.5])], [], [k1, k2])
    assert r.success and r.outer_iterations == 1
    x = r.values["x"]
    assert abs(x @ x - 4.0) <= 1e-3 and x[0] - x[1] >= -1e-3


def test_infeasible_constraints_are_reported_as_failure():
    a = Constraint(LinearBlock(("x",), [np.array([[1.0]])]), 1.0, 1.0, name="a")
    b = Constraint(LinearBlock(("x",), [np.array([[1.0]])]), -np.inf, 0.0, name="b")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.0])], [], [a, b], ALParams(max_iterations=200))
    assert not r.success
    assert r.max_violation == pytest.approx(0.5, abs=1e-2)  # the least-squares compromise x = 0.5
    assert "stalled" in r.reason or "outer" in r.reason or "budget" in r.reason


def test_constraint_bounds_are_validated():
    with pytest.raises(ValueError):
        Constraint(LinearBlock(("x",), [np.eye(2)]), [1.0, 0.0], [0.0, 1.0])
