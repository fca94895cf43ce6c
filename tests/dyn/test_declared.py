"""The centroidal problem built from declared constraint and cost names: the registry is the build order,
a builder switched off by its parameter adds no block, and declaring a builder is all a new constraint needs."""

import numpy as np

import legplan.dyn.problem as problem_module
from legplan.dyn.init import heuristic
from legplan.dyn.problem import (CONSTRAINTS, COSTS, PAPER, BuildContext, DynParams, DynTask, build_problem,
                                 constraint)
from legplan.solve.auglag import Constraint
from legplan.solve.blocks import LinearBlock

TASK = DynTask((0.0, 0.0, 0.0), (0.6, 0.0, 0.0), "trot", 2, 2.0)


def test_the_declared_names_are_the_problems_blocks_in_order(anymal, flat):
    legs = anymal.nominal_feet.shape[0]
    plain = build_problem(TASK, anymal, flat, DynParams(), heuristic)
    per_leg = ["range_of_motion", "stance_on_terrain", "stance_off_edges", "swing_above_terrain", "force"]
    assert [k.name for k in plain.constraints] == (["dynamics", "dynamics_between"] + ["acceleration_continuity"] * 2
                                                   + per_leg * legs  # a level map: no leg clearance rows
                                                   + ["base_clearance"] * legs)  # on by default: the check judges it
    paper = build_problem(TASK, anymal, flat, PAPER, heuristic)
    assert [k.name for k in paper.constraints][-legs - 1:] == ["swing_height"] + ["base_clearance"] * legs
    assert list(CONSTRAINTS)[:5] == ["last_phase", "dynamics", "dynamics_between", "acceleration_continuity", "swing"]
    assert {k.name for k in paper.constraints} <= set(CONSTRAINTS)
    assert {term.name for term in paper.costs} >= {"swing_height"} and list(COSTS) == ["stair_edge", "stance_width", "swing_height"]


def test_declaring_a_builder_adds_a_constraint(anymal, flat, monkeypatch):
    monkeypatch.setattr(problem_module, "CONSTRAINTS", dict(CONSTRAINTS))

    @constraint("goal_x_free", per_leg=False)
    def _goal(c: BuildContext):
        n = c.problem.variables[0].value.size
        return [Constraint(LinearBlock(("base_lin",), [np.eye(n)[:1]]), -np.inf, np.inf, name="goal_x_free")]

    built = build_problem(TASK, anymal, flat, DynParams(), heuristic)
    assert [k.name for k in built.constraints][-1] == "goal_x_free"
    assert "goal_x_free" not in CONSTRAINTS  # the module's registry was the patched copy
