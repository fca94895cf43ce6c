"""Constrained nonlinear least squares: an augmented Lagrangian whose subproblems are solved by LM.

    min_θ ½‖r(θ)‖²   subject to   l ≤ c(θ) ≤ u   (rows with l = u are equalities)

Why this scheme: the costs are sums of squares, so the augmented Lagrangian of a constraint row,
(μ/2)(c − l + y/μ)² for an equality or (μ/2)·max(0, c − u + y/μ)² for a bound, is a square too, and
every subproblem is again a sparse nonlinear least-squares problem, its bound rows hinged, for
`solve_hinged_lm` (LM whose steps minimize the hinge model exactly; CHOLMOD factorizes the normal
equations with one symbolic analysis per subproblem, since the pattern never changes).
Multipliers follow the first-order update y ← y + μ(c − l), y_u ← max(0, y_u + μ(c − u)); μ grows
by `mu_growth` whenever the violation did not fall below `violation_decrease` times the last one
(Nocedal & Wright, Alg. 17.4). They start at zero, or with `multipliers="least_squares"` at the
first-order estimate of the start point (`least_squares_multipliers`): from a feasible start, zero
multipliers let the first subproblem trade the constraints for the costs until the penalty alone
balances them, while the estimate makes the start nearly stationary, so the steps follow the
constraints. Without costs every feasible point is a solution with zero
multipliers: the subproblem is Gauss-Newton on the constraints themselves (a root of the residual is
a feasible point), as TOWR's feasibility problem, and further outer iterations only continue it.

The costs are typed terms (`CostTerm`: name, residual block, weight), each ½·weight·‖block‖².

Stopping rule (`ALResult.status`, a `legplan.solve.lm.Status`): CONVERGED when the largest
constraint violation is ≤ `violation_tolerance` (a row may keep up to `scaled_tolerance` of its
solver scale where that is looser, `row_tolerances`) and, if there are costs, the cost changed by less
than `cost_tolerance` (relative) over the last outer iteration — with least-squares multipliers the
first outer iteration's change counts from the start point (their estimate makes it an iterate of
the method, nearly stationary; zero multipliers make the first subproblem a different problem);
MAX_ITERATIONS when the iteration budget or `max_outer` is spent first, or, with `settled_exit`, once
the cost settled while a row is still outside its tolerance (a stage of constraints alone follows); STALLED when the violation stops falling (`stall_outer` outer
iterations in a row each keeping more than `stall_decrease` of it, with costs only once μ reached
`mu_max`: an infeasible local minimum); NUMERICAL_FAILURE when LM fails numerically.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

import scipy.sparse as sp

from legplan.geometry.sparse import wrapped
from legplan.parameters import Parameters, param
from legplan.solve.assembly import kept_indices, same_indices
from legplan.solve.blocks import ResidualBlock
from legplan.solve.hinged import HingedParams, solve_hinged_lm
from legplan.solve.linsolve import make_solver
from legplan.solve.lm import Status, Timings
from legplan.solve.problem import Problem
from legplan.solve.variables import VariableBlock


MULTIPLIER_PASSES = 8  # active-set passes of `least_squares_multipliers`


@dataclass(frozen=True)
class CostTerm:
    """One cost term: ½·`weight`·‖`block`(θ)‖², reported under `name` (terms of one name add up)."""

    name: str
    block: ResidualBlock
    weight: float


@dataclass
class Constraint:
    """lower ≤ block(θ) ≤ upper, row by row (equal bounds: an equality); `name` labels it in reports.

    `scale` (per row or scalar) multiplies the rows inside the solver only, so that rows in different
    units (N, m) weigh alike while infeasible; bounds and violations stay in the block's own units.
    """

    block: ResidualBlock
    lower: np.ndarray | float = 0.0
    upper: np.ndarray | float = 0.0
    name: str = ""
    scale: np.ndarray | float = 1.0

    def __post_init__(self):
        n = self.block.size
        self.lower = np.broadcast_to(np.asarray(self.lower, float), (n,)).copy()
        self.upper = np.broadcast_to(np.asarray(self.upper, float), (n,)).copy()
        self.scale = np.broadcast_to(np.asarray(self.scale, float), (n,)).copy()
        if np.any(self.lower > self.upper) or np.any(np.isnan(self.lower) | np.isnan(self.upper)):
            raise ValueError(f"constraint {self.name or type(self.block).__name__}: need lower ≤ upper")
        self.equality = self.lower == self.upper
        self.has_upper = ~self.equality & np.isfinite(self.upper)
        self.has_lower = ~self.equality & np.isfinite(self.lower)

    def violation(self, c: np.ndarray) -> np.ndarray:
        """Per-row violation ≥ 0 of values c."""
        return np.maximum(np.maximum(c - self.upper, self.lower - c), 0.0)


def row_tolerances(constraints: Sequence[Constraint], params: ALParams) -> list[np.ndarray]:
    """Per row of each constraint the violation within tolerance, in the row's own units: the
    larger of `violation_tolerance` and `scaled_tolerance` / the row's scale (a force row scaled
    per the robot's weight may keep that share of the weight)."""
    out = []
    for k in constraints:
        loose = params.scaled_tolerance / np.where(k.scale > 0.0, k.scale, np.inf)
        out.append(np.maximum(params.violation_tolerance, loose))
    return out


def scaled_violation(constraints: Sequence[Constraint], values: Sequence[np.ndarray]) -> float:
    """The largest row violation of `constraints` at their values `values` (one array each), each
    row times its scale (`Constraint.scale`): rows of different units on the solver's one scale."""
    return max((float(np.max(k.violation(c) * k.scale)) for k, c in zip(constraints, values) if c.size),
               default=0.0)


@dataclass(frozen=True)
class ALParams(Parameters):
    """Augmented-Lagrangian parameters (module docstring); `inner` are those of every subproblem (its
    max_iterations is the per-subproblem cap; `max_iterations` here caps the LM iterations of the
    whole solve)."""

    what = "augmented Lagrangian"

    inner: HingedParams = param(HingedParams(max_iterations=60, tolerance=0.0, function_tolerance=1e-4),
                                doc="the subproblems' hinged LM")
    violation_tolerance: float = param(1e-3, "(0, inf)", doc="converged once every constraint row is within this")
    cost_tolerance: float = param(1e-3, "[0, inf)", doc="and the cost changed by less, relative, over an outer iteration")
    mu_init: float = param(1.0, "(0, inf)", "μ₀", "initial penalty")
    mu_growth: float = param(10.0, "[1, inf)", doc="μ grows by this when the violation did not fall enough")
    mu_max: float = param(1e8, "[mu_init, inf)", doc="largest penalty")
    violation_decrease: float = param(0.25, "(0, 1]", doc="enough: the violation fell below this × the last one")
    max_outer: int = param(15, "[1, 1000]", doc="outer iterations (subproblems)")
    stall_decrease: float = param(0.9, "(0, 1]", doc=(
        "an outer iteration whose violation exceeds this × the last one made no progress"))
    stall_outer: int = param(2, "[1, 1000]", doc="stalled (infeasible local minimum) after this many such in a row")
    max_iterations: int = param(300, "[0, 100000]", doc="LM iterations of the whole solve")
    multipliers: str = param("zero", ("zero", "least_squares"), doc="initial multipliers (module docstring)")
    active_tolerance: float = param(1e-4, "[0, inf)", doc=(
        "least_squares: a bound row within this (scaled) of its bound is active"))
    scaled_tolerance: float = param(0.0, "[0, inf)", doc=(
        "a row also counts as within tolerance when its violation times its scale (`Constraint.scale`: "
        "forces per the robot's weight, lengths per 10 cm) is within this, where that is looser than "
        "violation_tolerance (`row_tolerances`); 0: violation_tolerance alone"))
    settled_exit: bool = param(False, (False, True), doc=(
        "with costs: stop (MAX_ITERATIONS) once the cost changed by less than cost_tolerance over an "
        "outer iteration while a row is still outside its tolerance, for a stage of the constraints "
        "alone to finish; off: raise μ and update the multipliers until the rows are within"))
    exact_rows: bool = param(False, (False, True), doc=(
        "without costs: stop a subproblem once every row is within violation_tolerance (|h_i| ≤ √μ·tol·w_i) "
        "instead of the norm test ‖h‖ ≤ √μ·tol·min(w), which assumes the worst row and solves further: "
        "that precision warm-starts a next stage, a last stage gains nothing from it"))


@dataclass
class ALResult:
    """Outcome of the solve: values, why it stopped, the constraint and cost picture, the effort."""

    values: dict[str, np.ndarray]  # the problem's variables (slacks left out)
    status: Status
    reason: str
    iterations: int
    outer_iterations: int
    max_violation: float
    violations: dict[str, float]
    cost: float
    cost_terms: dict[str, float]
    history: list[dict] = field(default_factory=list)
    timings: Timings = field(default_factory=Timings)
    first_iteration_seconds: float = 0.0
    scaled_violation: float = float("nan")  # `scaled_violation` of the constraints at `values`

    @property
    def success(self) -> bool:
        return self.status is Status.CONVERGED


class _AugmentedRows(ResidualBlock):
    """√μ·(w(c − l) + y/μ) on equality rows, √μ·(w(c − u) + y_u/μ) and √μ·(w(l − c) + y_l/μ) on the
    bounded rows, which are hinged (`hinged`: the residual is max(0, ·) there): the augmented
    Lagrangian of one `Constraint` as least-squares rows, w its row scale.

    A row bounded on both sides has two residual rows whose derivatives are ±√μ·w·∂c: they share
    one Jacobian row (`jacobian_rows`, `jacobian_sign`: the lower bound's is the upper's negated),
    so its derivative is picked, stored and multiplied once (`Problem.row_map`)."""

    def __init__(self, constraint: Constraint):
        self.constraint = constraint
        self.variables = constraint.block.variables
        k = constraint
        self.rows = (np.flatnonzero(k.equality), np.flatnonzero(k.has_upper), np.flatnonzero(k.has_lower))
        self.pick = np.concatenate(self.rows)
        self.sign = np.concatenate([np.ones(self.rows[0].size + self.rows[1].size), -np.ones(self.rows[2].size)])
        self.bound = np.concatenate([k.lower[self.rows[0]], k.upper[self.rows[1]], k.lower[self.rows[2]]])
        self.hinged = np.concatenate([np.zeros(self.rows[0].size, bool), np.ones(self.rows[1].size + self.rows[2].size, bool)])
        self.size = self.pick.size
        self.mu = 1.0
        self.y = np.zeros(self.size)
        self._pickers: list[_RowPicker] = []
        self._last: tuple[list[np.ndarray], np.ndarray] | None = None  # `constraint_values`' reuse
        self._kept_scaling: tuple | None = None  # `_scaling`
        self._every_row = self.pick.size == constraint.block.size and np.array_equal(self.pick, np.arange(self.size))
        # Jacobian rows: the equality and upper-bound rows, then the lower-bound rows without an upper
        # bound; a lower-bound row with one shares that row, negated
        before = self.rows[0].size + self.rows[1].size
        upper_at = np.full(constraint.block.size, -1, np.int64)
        upper_at[self.rows[1]] = self.rows[0].size + np.arange(self.rows[1].size)
        shared = upper_at[self.rows[2]]
        own = shared < 0
        lower_rows = np.where(own, before + np.cumsum(own) - 1, shared)
        if not own.all():
            self.jacobian_rows = np.concatenate([np.arange(before), lower_rows])
            self.jacobian_sign = np.where(np.concatenate([np.ones(before, bool), own]), 1.0, -1.0)
            self._jacobian_pick = np.concatenate([np.arange(before), before + np.flatnonzero(own)])
        else:
            self._jacobian_pick = None

    def _scaling(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """√μ·sign·w per residual row, y/√μ, and the factor of the Jacobian's rows: kept while μ and
        the multipliers' array are the ones they were made for (`update` and the solver assign new
        ones)."""
        kept = self._kept_scaling
        if kept is None or kept[0] != self.mu or kept[1] is not self.y:
            factor = np.sqrt(self.mu) * self.sign * self.constraint.scale[self.pick]
            pick = self._jacobian_pick
            kept = self._kept_scaling = (self.mu, self.y, factor, self.y / np.sqrt(self.mu),
                                         factor if pick is None else factor[pick])
        return kept[2], kept[3], kept[4]

    def evaluate(self, values, jacobians):
        c, jacs = self.constraint.block.evaluate(values, jacobians)
        c = np.asarray(c, float)
        factor, shift, row_factor = self._scaling()
        r = factor * ((c if self._every_row else c[self.pick]) - self.bound) + shift
        if not jacobians:  # copies: a caller may change its arrays in place, a block reuse its buffers
            self._last = ([np.array(v, float) for v in values], c.copy())
            return r, None
        pick = self._jacobian_pick
        if not self._pickers:
            self._pickers = [_RowPicker(self.pick if pick is None else self.pick[pick]) for _ in jacs]
        return r, [picker(j, row_factor) for picker, j in zip(self._pickers, jacs)]

    def residual_rows(self, values, rows):
        """`evaluate`'s rows `rows` from the constraint rows they bound alone (a row bounded on both
        sides is evaluated once for both)."""
        needed, at = np.unique(self.pick[rows], return_inverse=True)
        c = np.asarray(self.constraint.block.residual_rows(values, needed), float)[at]
        factor = np.sqrt(self.mu) * self.sign[rows] * self.constraint.scale[self.pick[rows]]
        return factor * (c - self.bound[rows]) + self.y[rows] / np.sqrt(self.mu)

    def constraint_values(self, values) -> np.ndarray:
        """c(θ) of the constraint at the variable values `values`: the values of this block's last
        evaluation without Jacobians when it read these very values (the hinged LM's last trial
        point is the subproblem's solution, whose constraint values the outer iteration reads
        next), else evaluated. A Jacobian evaluation is never reused: a block may form its residual
        there another way (complex steps), equal only to rounding."""
        last = self._last
        if last is not None and len(last[0]) == len(values) and all(
                np.array_equal(a, b) for a, b in zip(last[0], values)):
            return last[1].copy()
        return np.asarray(self.constraint.block.evaluate(values, False)[0], float)

    def update(self, c: np.ndarray) -> None:
        """First-order multiplier update at the subproblem's solution (of the scaled rows); the
        multipliers of bound rows stay ≥ 0."""
        v = self.sign * self.constraint.scale[self.pick] * (c[self.pick] - self.bound)
        y = self.y + self.mu * v
        y[self.hinged] = np.maximum(y[self.hinged], 0.0)
        self.y = y  # a new array: `_scaling` takes it


class _RowPicker:
    """diag(factor)·J[pick] of a Jacobian block J, sparsity pattern (explicit zeros) kept. A block's
    Jacobian keeps its pattern from call to call, so where its rows' entries go is worked out once
    per pattern (`_picked_pattern`) and each call is one gather and one product instead of scipy's
    row indexing and row scaling (no gather where every entry stays in its place)."""

    def __init__(self, pick: np.ndarray):
        self.pick = np.asarray(pick, np.int64)
        self.pattern = None

    def __call__(self, jac, factor: np.ndarray):
        if not sp.issparse(jac):
            return factor[:, None] * np.asarray(jac, float)[self.pick]
        jac = jac if jac.format == "csr" else sp.csr_matrix(jac)
        if self.pattern is None or not (self.pattern[0] == jac.shape
                                        and same_indices(self.pattern[1], (jac.indptr, jac.indices))):
            if self.pick.size == jac.shape[0] and np.array_equal(self.pick, np.arange(self.pick.size)):
                picked = _every_row_pattern(jac.shape, jac.indptr, jac.indices)
            else:
                picked = _picked_pattern(jac.shape, jac.indptr.dtype.str, jac.indptr.tobytes(),
                                         jac.indices.dtype.str, jac.indices.tobytes(), self.pick.tobytes())
            source = picked[0]
            if source.size == jac.data.size and np.array_equal(source, np.arange(source.size)):
                source = None  # every entry in its place (each row picked once, in order): no gather
            self.pattern = (jac.shape, kept_indices((jac.indptr, jac.indices)), None, source, *picked[1:])
        _, _, _, source, indices, indptr, row = self.pattern
        data = jac.data * factor[row] if source is None else jac.data[source] * factor[row]
        return wrapped(sp.csr_matrix, data, indices, indptr, (self.pick.size, jac.shape[1]))


def _every_row_pattern(shape, indptr: np.ndarray, indices: np.ndarray) -> tuple:
    """`_picked_pattern` of a pick of every row in order (a constraint bounded on both sides in every
    row, the most common): the pattern itself in scipy's index dtype, every entry in its place."""
    index = np.int32 if max(*shape, indices.size) <= np.iinfo(np.int32).max else np.int64  # scipy's choice
    count = np.diff(indptr.astype(np.int64))
    out = (np.arange(indices.size, dtype=np.int64), indices.astype(index), indptr.astype(index),
           np.repeat(np.arange(shape[0]), count))
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=256)
def _picked_pattern(shape, ptr_dtype, ptr, idx_dtype, idx, pick) -> tuple:
    """For a CSR pattern (dtypes and bytes of indptr, indices) and the picked rows (int64 bytes): the
    entry numbers of the picked rows' entries, their CSR indices and indptr, and their rows (read-only,
    shared). Cached by content: the same constraints recur in every stage's problem and every task."""
    indptr, indices, pick = np.frombuffer(ptr, ptr_dtype), np.frombuffer(idx, idx_dtype), np.frombuffer(pick, np.int64)
    index = np.int32 if max(*shape, indices.size) <= np.iinfo(np.int32).max else np.int64  # scipy's choice
    count = np.diff(indptr.astype(np.int64))[pick]
    picked_ptr = np.zeros(pick.size + 1, np.int64)
    np.cumsum(count, out=picked_ptr[1:])
    row = np.repeat(np.arange(pick.size), count)
    source = indptr[pick].astype(np.int64)[row] + (np.arange(picked_ptr[-1]) - picked_ptr[row])  # each row's run
    out = (source, indices[source].astype(index), picked_ptr.astype(index), row)
    for a in out:
        a.flags.writeable = False
    return out


def solve_augmented_lagrangian(variables: Sequence[VariableBlock], costs: Sequence[CostTerm],
                               constraints: Sequence[Constraint], params: ALParams = ALParams(),
                               callback: Callable[[int, float, float], None] | None = None,
                               deadline: float | None = None) -> ALResult:
    """Solve min Σ w‖r‖² s.t. the constraints from the variables' current values (see module docstring).

    `callback(iteration, violation, cost)` is called after every subproblem. `deadline` (a
    `time.process_time()` value, or None): no LM step starts after it; the solve stops where it is
    (`Status.TIME_LIMIT`), as at its iteration budget.
    """
    t_start = time.perf_counter()
    problem = Problem(list(variables))
    for term in costs:
        problem.add_residual(term.block, np.sqrt(term.weight))
    rows = [problem.add_residual(_AugmentedRows(k)) for k in constraints]
    theta = problem.layout.initial()
    last_cost = None
    if costs and params.multipliers == "least_squares":
        least_squares_multipliers(problem, rows, theta, params.active_tolerance)
        # the estimate makes the start a point of the outer iteration: the first one's cost change counts
        last_cost = sum(evaluate_costs(costs, problem.layout.values(theta)).values())
    # without costs (multipliers 0) a subproblem is done once every row is within tolerance: |h_i| ≤ √μ·tol·w_i
    # (`exact_rows`), for which ‖h‖ ≤ √μ·tol·min(w) suffices
    exact = not costs and params.exact_rows
    tolerances = row_tolerances(constraints, params)
    # w_i, times tol_i / violation_tolerance where `scaled_tolerance` loosens row i
    widen = ([t / params.violation_tolerance for t in tolerances] if params.scaled_tolerance
             else [1.0] * len(constraints))
    row_scale = np.concatenate([(r.constraint.scale * f)[r.pick] for r, f in zip(rows, widen)]
                               or [np.ones(0)]) if exact else None
    min_scale = min((float((k.scale * f).min()) for k, f in zip(constraints, widen) if k.block.size), default=1.0)
    timings = Timings()
    history: list[dict] = []
    iterations = 0
    first_iteration = 0.0
    mu = params.mu_init
    last_violation = np.inf
    stalled = 0
    status, reason = Status.MAX_ITERATIONS, ""
    for outer in range(1, params.max_outer + 1):
        for r in rows:
            r.mu = mu
        budget = params.max_iterations - iterations
        inner = replace(params.inner, max_iterations=min(params.inner.max_iterations, budget),
                        tolerance=np.sqrt(mu) * params.violation_tolerance * min_scale
                        if not costs and not exact else params.inner.tolerance)
        t_lm = time.perf_counter()
        result = solve_hinged_lm(problem, inner, theta0=theta,
                                 row_tolerance=np.sqrt(mu) * params.violation_tolerance * row_scale if exact else None,
                                 deadline=deadline)
        if outer == 1 and result.iterations:
            first_iteration = (time.perf_counter() - t_lm) / result.iterations
        iterations += result.iterations
        theta = result.theta
        for name in ("evaluate", "assemble", "factorize", "solve"):
            setattr(timings, name, getattr(timings, name) + getattr(result.timings, name))
        values = problem.layout.values(theta)
        c_now = [r.constraint_values([values[v] for v in r.variables]) for r in rows]
        violation = max((float(k.violation(c).max()) if c.size else 0.0 for k, c in zip(constraints, c_now)),
                        default=0.0)
        cost_terms = evaluate_costs(costs, values)
        cost = sum(cost_terms.values())
        history.append({"outer": outer, "iterations": result.iterations, "violation": violation, "cost": cost,
                        "mu": mu, "lm": result.reason,
                        "stopped_by": result.stopped_by})
        if callback is not None:
            callback(iterations, violation, cost)
        if result.status is Status.NUMERICAL_FAILURE:
            status, reason = Status.NUMERICAL_FAILURE, f"numerical failure: {result.reason}"
            break
        cost_settled = (not costs or (last_cost is not None and
                                      abs(last_cost - cost) <= params.cost_tolerance * max(abs(cost), 1e-12)))
        within = all(np.all(k.violation(c) <= t) for k, c, t in zip(constraints, c_now, tolerances) if c.size)
        if within and cost_settled:
            status = Status.CONVERGED
            reason = (f"max violation {violation:.2e} ≤ {params.violation_tolerance:.0e}"
                      + (f" or {params.scaled_tolerance:.0e} of its row scale" if params.scaled_tolerance else "")
                      + (f", cost change ≤ {params.cost_tolerance:.0e} relative" if costs else ""))
            break
        if params.settled_exit and costs and cost_settled:
            reason = (f"cost settled (change ≤ {params.cost_tolerance:.0e} relative) with max violation "
                      f"{violation:.2e}: the constraints are left to the next stage")
            break
        if iterations >= params.max_iterations:
            reason = f"iteration budget {params.max_iterations} spent with max violation {violation:.2e}"
            break
        if result.status is Status.TIME_LIMIT:
            status, reason = Status.TIME_LIMIT, f"CPU time budget spent with max violation {violation:.2e}"
            break
        no_progress = violation > params.stall_decrease * last_violation and (not costs or mu >= params.mu_max)
        stalled = stalled + 1 if no_progress else 0
        if stalled >= params.stall_outer:
            status = Status.STALLED
            reason = (f"stalled infeasible: max violation {violation:.2e} fell by less than "
                      f"{1 - params.stall_decrease:.0%} over {params.stall_outer} outer iterations (local minimum)")
            break
        if costs:  # without costs every feasible point is optimal: multipliers 0, nothing to update
            for r, c in zip(rows, c_now):
                r.update(c)
            if violation > params.violation_decrease * last_violation:
                mu = min(mu * params.mu_growth, params.mu_max)
        last_violation, last_cost = violation, cost
    else:
        reason = f"{params.max_outer} outer iterations with max violation {violation:.2e}"
    timings.total = time.perf_counter() - t_start
    per_constraint = {}
    for k, c in zip(constraints, c_now):
        label = k.name or type(k.block).__name__
        per_constraint[label] = max(per_constraint.get(label, 0.0), float(k.violation(c).max()) if c.size else 0.0)
    values = {v.name: values[v.name] for v in variables}
    return ALResult(values, status, reason, iterations, len(history), violation, per_constraint, cost,
                    cost_terms, history, timings, first_iteration, scaled_violation(constraints, c_now))


def least_squares_multipliers(problem: Problem, rows: Sequence[_AugmentedRows], theta: np.ndarray,
                              active_tolerance: float) -> None:
    """Set the multipliers of `rows` (the problem's last residual blocks, after its costs) to the
    first-order estimate at θ: y = argmin ‖∇f + J_Aᵀ y‖ over the rows A active at θ (equalities, and
    bound rows within `active_tolerance` of their bound or beyond), with y ≥ 0 on bound rows
    (Nocedal & Wright, eq. (18.21)). J_A are the scaled constraint rows s·∂c/∂θ, ∇f = J_fᵀ r_f of
    the cost rows. The sign condition by an active-set loop: solve on A (regularized by 1e-10 of the largest
    diagonal entry of J_A J_Aᵀ, so redundant rows get the least-norm split),
    drop the bound rows whose y came out negative, repeat (at most `MULTIPLIER_PASSES` times; then
    the remaining negatives are clipped; clipping alone can leave an estimate worse than zero).
    Each pass is the regularized least-norm solution y = −(J_A J_Aᵀ + δI)⁻¹ J_A ∇f, formed on the smaller
    side of the push-through identity (`_least_norm_multipliers`): the dynamics' many sample rows over
    few coefficients make J_A J_Aᵀ far larger (and denser) than J_Aᵀ J_A."""
    for r in rows:
        r.mu, r.y = 1.0, np.zeros(r.size)
    v, J = problem.jacobian(theta)
    m = sum(r.size for r in rows)
    k = v.size - m
    J = sp.csr_matrix(J)
    shared = problem.row_map()
    if shared is not None:  # one row per residual row: diag(sign)·J[jrow]
        J = J[shared[0]]
        J.data *= np.repeat(shared[1], np.diff(J.indptr))
    g = J[:k].T @ v[:k]
    Jc = J[k:]
    hinged = problem.hinge_mask()[k:]
    active = ~hinged | (v[k:] > -active_tolerance)
    y = np.zeros(m)
    pick = np.flatnonzero(active)  # passes only drop rows: theirs are zeroed, so one analysis serves all
    if pick.size:
        solver = make_solver("cholmod")
        A = sp.csr_matrix(Jc[pick], copy=True)
        values, row_of_entry = A.data.copy(), np.repeat(np.arange(pick.size), np.diff(A.indptr))
        diagonal = np.asarray(A.multiply(A).sum(axis=1)).ravel()
    for _ in range(MULTIPLIER_PASSES):
        y[:] = 0.0
        if not active[pick].any():
            break
        keep = active[pick]
        A.data = values * keep[row_of_entry]
        delta = 1e-10 * max(float(diagonal[keep].max()), 1e-300)
        y[pick] = np.where(keep, _least_norm_multipliers(solver, A, g, delta), 0.0)
        wrong = hinged & (y < 0.0)
        if not wrong.any():
            break
        active &= ~wrong
    y[hinged] = np.maximum(y[hinged], 0.0)
    offset = 0
    for r in rows:
        r.y = y[offset:offset + r.size].copy()
        offset += r.size


def _least_norm_multipliers(solver, A: sp.csr_matrix, g: np.ndarray, delta: float) -> np.ndarray:
    """y = −(A Aᵀ + δI)⁻¹ A g, the regularized least-norm solution of Aᵀ y = −g, factorized on the
    smaller side: (A Aᵀ + δI)⁻¹ A = A (Aᵀ A + δI)⁻¹ (push-through identity), so with more rows than
    columns y = −A (Aᵀ A + δI)⁻¹ g. CHOLMOD's AAᵀ mode either way (`set_jacobian` of J factorizes
    JᵀJ + βI), the same analysis for every pass of one estimate."""
    if A.shape[0] > A.shape[1]:
        solver.set_jacobian(A)
        solver.refactor(delta)
        return -(A @ solver.solve(g))
    solver.set_jacobian(A.T)
    solver.refactor(delta)
    return solver.solve(-(A @ g))


def evaluate_costs(costs: Sequence[CostTerm], values) -> dict[str, float]:
    """½·w·‖r‖² of every `CostTerm` at the variable values (terms of one name summed)."""
    out: dict[str, float] = {}
    for term in costs:
        r = term.block.evaluate([values[v] for v in term.block.variables], False)[0]
        out[term.name] = out.get(term.name, 0.0) + 0.5 * term.weight * float(np.dot(r, r))
    return out
