"""Sparse nonlinear least squares: residual blocks + Levenberg-Marquardt (Algorithm 1, eq. (13)).

    problem = Problem([VariableBlock("x", x0), VariableBlock("xi", xi0, schur_block=3)])
    problem.add_residual(FunctionBlock(["x", "xi"], m, fn))          # fn(x, xi) -> (r, [Jx, Jxi])
    problem.add_residual(HingeInequality(FunctionBlock(["x"], k, g)))  # g(x) ≤ 0, eq. (8b)
    result = solve_lm(problem, LMParams(max_iterations=100, linear_solver="cholmod"))
    result.status, result.reason, result.values["x"], result.timings

A block that knows its JᵀJ derives from `StructuredBlock` and returns `NormalTerms` (dense,
sparse or `BlockDiagonal` JᵀJ pieces and Jᵀh); variables with `schur_block` are eliminated by a
Schur complement before factorising. Test every block with `check_jacobian(block, values)`.
"""

from legplan.lazy_exports import lazy_exports

# Names load with their module on first use (PEP 562): a planner importing the blocks and one solver does
# not import the others, the Jacobian checker or the Schur solver.
_HOMES = {
    **dict.fromkeys(("BlockDiagonal", "FunctionBlock", "NormalTerms", "ResidualBlock", "StructuredBlock"), "blocks"),
    **dict.fromkeys(("HingeInequality", "IntervalPenalty"), "inequality"),
    **dict.fromkeys(("JacobianCheck", "check_jacobian", "check_normal_terms", "numeric_jacobian"), "jaccheck"),
    **dict.fromkeys(("CholmodSolver", "DenseSolver", "LinearSolver", "NotPositiveDefiniteError", "ScipySolver",
                     "make_solver"), "linsolve"),
    **dict.fromkeys(("LMParams", "LMResult", "Status", "Timings", "solve_lm"), "lm"),
    **dict.fromkeys(("NormalEquations", "Problem", "SchurParts"), "problem"),
    "SchurSolver": "schur",
    **dict.fromkeys(("VariableBlock", "VariableLayout"), "variables"),
}
__getattr__, __dir__ = lazy_exports(__name__, _HOMES)

__all__ = [
    "BlockDiagonal", "CholmodSolver", "DenseSolver", "FunctionBlock", "HingeInequality", "IntervalPenalty",
    "JacobianCheck", "LMParams", "LMResult", "LinearSolver", "NormalEquations", "NormalTerms",
    "NotPositiveDefiniteError", "Problem", "ResidualBlock", "SchurParts", "SchurSolver", "ScipySolver", "Status",
    "StructuredBlock", "Timings", "VariableBlock", "VariableLayout", "check_jacobian", "check_normal_terms",
    "make_solver", "numeric_jacobian", "solve_lm",
]
