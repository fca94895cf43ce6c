"""Levenberg-Marquardt for residuals of which some are hinged, r_i = max(0, v_i), with exact model steps.

Inequality constraints enter a least-squares problem as hinged rows (eq. (8b) of the Bézier paper,
or the bound rows of an augmented Lagrangian). Plain LM linearizes max(0, v) at the current point
only: a row inactive there is invisible to the step, which then overshoots it and is rejected, and
λ cycles. Here each step minimizes the piecewise-quadratic model of the hinges themselves,

    m(d) = ‖v_E + J_E d‖² + ‖max(0, v_H + J_H d)‖² + λ‖S⁻¹d‖²,   S = diag(JᵀJ)^(-1/2) (Marquardt),

by a primal active-set (semi-smooth Newton) loop: with A the hinged rows active at the model point
d, solve the damped normal equations of the rows E ∪ A for d⁺, move d to the minimizer of m on the
segment [d, d⁺] (m is convex and piecewise quadratic along a line: `_model_line_search`, one sorted
pass over the hinges' breakpoints), recompute A there, repeat until A is stable at a full move (at
most `active_set_iterations`). Every pass lowers m, so a step never predicts an increase of ‖h‖, and
the loop cannot cycle when many hinges cross at once.

Every solve is a numeric factorization by CHOLMOD of J_RᵀJ_R + λI from the rows R of J that are
plain or active (its AAᵀ mode: no product formed in Python), on one symbolic analysis of the whole
J's pattern, at the first pass of a step. J is `Problem.nonzero_jacobian`: the entries that are
zero by construction (zero blocks of per-sample Jacobians, forces fixed at zero in swing) never
enter the products, and its pattern, the entries ever nonzero, settles after a few
linearizations, each change one new analysis. The later passes change a few rows, which the
factor follows by CHOLMOD's rank updates (`CholmodSolver.refactor_rows`), and a pass whose
active set is the one last factorized reuses that factorization. λ follows the gain ratio
ρ = actual / model decrease (Nielsen: λ ← λ·max(⅓, 1 − (2ρ − 1)³) on success, λ ← λ·ν, ν ← 2ν on
failure; the ⅓ is `lambda_decrease`, which a problem whose model is nearly exact near its start, a
projection onto nearly linear constraints, lowers: at ρ ≈ 1 a damped step keeps the share λ/(σ² + λ)
of the residual along each scaled singular value σ of J, so a λ that falls slowly converges linearly).

Geodesic acceleration (Transtrum & Sethna, "Improvements to the Levenberg-Marquardt algorithm for
nonlinear least-squares minimization", 2012, eq. (14)): the step d is a velocity along the model;
the residuals' curvature along it, r_vv ≈ (2/h)((r(θ + hd) − r(θ))/h − Jd) with h = 0.1 (one more
residual evaluation, of the plain and active rows alone: `Problem.residual_rows`), gives the acceleration a = −(JᵀJ + λI)⁻¹ Jᵀ r_vv from the step's own
factorization (rows E ∪ A), and the trial point is θ + d + ½a when 2‖a‖ ≤ α‖d‖ (α =
`geodesic_acceleration`, 0.75 as the paper recommends; 0 switches it off).

Rows that share a Jacobian row up to sign (`Problem.row_map`: the two bounds of one constraint row,
l ≤ c ≤ u, whose derivatives are ±∂c) keep their own residuals and hinges; J holds the shared row
once, J_full = diag(s)·J[jrow], and every product with J_full (J d, Jᵀx, the Marquardt scale, the
rows of J_RᵀJ_R and its rank updates) reads J through that map, row by row in the residual rows'
order: the same sums in the same order as with J_full stored (a sign changes no product's
magnitude), on about half the entries where most rows are bounded on both sides.

Box bounds of the variables (`VariableBlock.lower`/`upper`): a variable on a bound that the
descent direction −Jᵀh points out of is held there for the step (`held_at_bounds`: its column and
its scale zero, the active set of bound-constrained Gauss–Newton), the trial point is clipped to the
box and ρ compares the decrease with the model's at the clipped step; the gradient test reads the
gradient of the variables not held. A step computed for all variables and clipped afterwards moves
the free ones as if the held one had moved too, predicts a decrease it does not make and, rejected,
drives λ up while the point sits on the bound.

Stops (`_Stopping`, the result's `status` and `stopped_by`): ‖h‖ < `tolerance` or, given
`row_tolerance`, every row within its own, |h_i| ≤ row_tolerance_i (converged: tested on the trial
residual, so the point that meets it costs no Jacobian); an accepted step lowering ‖h‖² by less
than `function_tolerance` relative, or a gradient ‖Jᵀh‖∞ below `gradient_tolerance` times its
initial value (converged: the minimum of a problem with costs); `max_iterations`; λ > `lambda_max`
(stalled); a non-finite residual or Jacobian (numerical failure); a `deadline` of CPU time passed
before a step (time limit: the point reached, the best so far, as every accepted step lowers ‖h‖;
the budget of a solve that must answer in time, as a replan in closed loop).

At DEBUG level every step logs λ, the step's size, the model's and the actual decrease of ‖h‖², ‖h‖ of the
plain and of the hinged rows, and the hinged rows active at the point, in the model and at the trial
point (`_trace_step`): what tells a damping-limited step (ρ ≈ 1, small decrease) from a hinge change.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from legplan.geometry.sparse import times, wrapped
from legplan.parameters import Parameters, param
from legplan.solve.linsolve import CholmodSolver, NotPositiveDefiniteError
from legplan.solve.lm import MARQUARDT_FLOOR, LMResult, Status, Timings
from legplan.solve.problem import Problem

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class HingedParams(Parameters):
    """Parameters of `solve_hinged_lm` (module docstring)."""

    what = "hinged LM"

    lambda_init: float = param(1e-4, "(0, inf)", "λ₀", "initial damping")
    lambda_max: float = param(1e12, "(0, inf)", doc="stalled once λ exceeds this")
    lambda_decrease: float = param(1 / 3, "(0, 1)", doc=(
        "smallest factor of λ after an accepted step (Nielsen's update, module docstring: reached when "
        "the gain ratio ρ is near 1, the model as good as exact)"))
    max_iterations: int = param(100, "[0, 100000]", doc="LM iterations (each one factorization)")
    tolerance: float = param(1e-10, "[0, inf)", doc="converged once ‖h‖ < this")
    function_tolerance: float = param(0.0, "[0, 1]", doc="converged once an accepted step lowers ‖h‖² by less, relative")
    gradient_tolerance: float = param(1e-10, "[0, 1]", doc="converged once ‖Jᵀh‖∞ falls below this × its initial value")
    active_set_iterations: int = param(10, "[1, 1000]", doc="passes of the active-set loop per step")
    geodesic_acceleration: float = param(0.75, "[0, inf)", "α", "add ½a when 2‖a‖ ≤ α‖d‖; 0: off")


def hinged_norm(v: np.ndarray, hinged: np.ndarray) -> float:
    """‖h‖ with h_i = max(0, v_i) on hinged rows and v_i elsewhere."""
    return float(np.linalg.norm(np.where(hinged, np.maximum(v, 0.0), v)))


def solve_hinged_lm(problem: Problem, params: HingedParams = HingedParams(), theta0: np.ndarray | None = None,
                    row_tolerance: np.ndarray | None = None, deadline: float | None = None) -> LMResult:
    """Minimize ‖h(θ)‖ (hinged rows per `problem.hinge_mask()`) from θ0 (see module docstring).

    `row_tolerance` (one per row, or None): converged once every |h_i| is within it — the exact test
    of a root within tolerance per row, where a norm tolerance must assume the worst row.
    `deadline` (a `time.process_time()` value, or None): no step starts after it (`Status.TIME_LIMIT`)."""
    t_start = time.perf_counter()
    layout = problem.layout
    hinged = problem.hinge_mask()
    timings = Timings()
    theta = layout.initial() if theta0 is None else layout.project(np.array(theta0, float))
    solver = problem.structure_cache.get("cholmod")  # its symbolic analysis holds for the next solve too
    if solver is None:  # CHOLMOD's own ordering: deciding on the natural one costs a structural JᵀJ
        solver = problem.structure_cache["cholmod"] = CholmodSolver(ordering_method="default")
    lam, nu = params.lambda_init, 2.0
    hist_h, hist_l = [], []
    accepted = rejected = 0

    def finish(stop: tuple[Status, str, str], it: int, norm: float) -> LMResult:
        status, test, reason = stop
        timings.total = time.perf_counter() - t_start
        log.info("hinged LM %s after %d iterations: ‖h‖=%.3e (%s)", status.value, it, norm, reason)
        return LMResult(theta, layout.values(theta), status, reason, it, norm, initial, hist_h, hist_l,
                        accepted, rejected, timings, test)

    rows = problem.row_map()
    t0 = time.perf_counter()
    v, J = problem.nonzero_jacobian(theta)
    timings.evaluate += time.perf_counter() - t0
    norm = initial = hinged_norm(v, hinged)
    model = None
    held = held_at_bounds(layout, theta, J, v, hinged, rows)
    stopping = _Stopping(params, hinged, row_tolerance, rows)
    expansion = problem.structure_cache.setdefault("row_expansion", _RowExpansion())
    for it in range(params.max_iterations + 1):
        stop = stopping.at_point(it, norm, v, J, lam, held) or _past(deadline)
        if stop:
            return finish(stop, it, norm)
        if model is None:
            t0 = time.perf_counter()
            model = _HingeModel(J, v, hinged, layout.n, held, rows, expansion)
            timings.assemble += time.perf_counter() - t0
        step = model.step(solver, lam, params.active_set_iterations, timings)
        if step is None:
            lam, nu = lam * nu, 2 * nu
            rejected += 1
            continue
        scaled_step = step
        step = model.scale * step
        taken = layout.project(theta + step) - theta if layout.bounded else step  # clipped to the box
        predicted = norm ** 2 - hinged_norm(v + _times(J, taken, rows), hinged) ** 2
        if params.geodesic_acceleration > 0.0:
            t0 = time.perf_counter()
            probe = problem.residual_rows(layout.project(theta + GEODESIC_PROBE * step), model.rows_read())
            timings.evaluate += time.perf_counter() - t0
            acceleration = model.acceleration(solver, (probe - v) / GEODESIC_PROBE - _times(J, step, rows),
                                              GEODESIC_PROBE)
            if 2.0 * np.linalg.norm(acceleration) <= params.geodesic_acceleration * np.linalg.norm(scaled_step):
                step = step + 0.5 * model.scale * acceleration
        trial = layout.project(theta + step)
        t0 = time.perf_counter()
        trial_v = problem.residual(trial)
        trial_norm = hinged_norm(trial_v, hinged)
        timings.evaluate += time.perf_counter() - t0
        if log.isEnabledFor(logging.DEBUG):
            _trace_step(it, lam, scaled_step, step, norm, trial_norm, predicted, v, trial_v, hinged, model)
        if trial_norm < norm:
            decrease = 1.0 - (trial_norm / norm) ** 2
            rho = min((norm ** 2 - trial_norm ** 2) / max(predicted, 1e-300), 2.0)
            lam, nu = max(lam * max(params.lambda_decrease, 1 - (2 * rho - 1) ** 3), 1e-20), 2.0
            theta, norm = trial, trial_norm
            accepted += 1
            hist_h.append(norm), hist_l.append(lam)
            stop = stopping.after_step(norm, trial_v, decrease) or stopping.spent(it + 1, norm)
            if stop:  # no linearization at a point no step leaves
                return finish(stop, it + 1, norm)
            t0 = time.perf_counter()
            v, J = problem.nonzero_jacobian(theta)
            model = None
            held = held_at_bounds(layout, theta, J, v, hinged, rows)
            timings.evaluate += time.perf_counter() - t0
        else:
            lam, nu = lam * nu, 2 * nu
            rejected += 1
            hist_h.append(norm), hist_l.append(lam)
    raise AssertionError("unreachable: the loop returns at it == max_iterations")


def _trace_step(it: int, lam: float, scaled_step: np.ndarray, step: np.ndarray, norm: float, trial_norm: float,
                predicted: float, v: np.ndarray, trial_v: np.ndarray, hinged: np.ndarray, model: _HingeModel) -> None:
    """One debug line per step: λ, the step (scaled and in the variables), the model's and the actual
    decrease of ‖h‖², ‖h‖ of the plain and of the hinged rows before and after, and the hinged rows
    active at the point, in the step's model and at the trial point."""
    def parts(x):
        return np.linalg.norm(x[~hinged]), np.linalg.norm(np.maximum(x[hinged], 0.0))

    (plain, hinge), (trial_plain, trial_hinge) = parts(v), parts(trial_v)
    now, modelled, then = hinged & (v > 0), model.active, hinged & (trial_v > 0)
    log.debug("step %d: λ=%.2e ‖d‖=%.3e (scaled %.3e) ‖h‖² %.4e → %.4e predicted %.4e actual %.4e; "
              "plain ‖h‖ %.3e → %.3e, hinged %.3e → %.3e; active %d, model %d (+%d −%d), trial %d (+%d −%d)",
              it, lam, np.linalg.norm(step), np.linalg.norm(scaled_step), norm ** 2, trial_norm ** 2, predicted,
              norm ** 2 - trial_norm ** 2, plain, trial_plain, hinge, trial_hinge, now.sum(), modelled.sum(),
              (modelled & ~now).sum(), (now & ~modelled).sum(), then.sum(), (then & ~now).sum(), (now & ~then).sum())


class _Stopping:
    """The stop tests of `solve_hinged_lm` (module docstring) as (status, parameter, reason), None to go
    on: `at_point` before a step from the current point, `after_step` at an accepted trial point."""

    def __init__(self, params: HingedParams, hinged: np.ndarray, row_tolerance: np.ndarray | None, rows=None):
        self.params, self.hinged, self.row_tolerance, self.rows = params, hinged, row_tolerance, rows
        self.initial_gradient = None

    def at_point(self, it: int, norm: float, v: np.ndarray, J, lam: float,
                 held: np.ndarray | None = None) -> tuple[Status, str, str] | None:
        """`held`: the variables a bound holds (`held_at_bounds`), whose gradient is no descent left."""
        p = self.params
        if not np.isfinite(norm) or not np.all(np.isfinite(J.data)):
            return Status.NUMERICAL_FAILURE, "", "residual or Jacobian not finite at the current point"
        h = np.where(self.hinged, np.maximum(v, 0.0), v)
        stop = self._within_tolerance(norm, h)
        if stop:
            return stop
        g = _transposed_times(J, h, self.rows)  # inactive hinged rows contribute nothing
        gradient = float(np.abs(g if held is None else np.where(held, 0.0, g)).max(initial=0.0))
        if self.initial_gradient is None:
            self.initial_gradient = gradient
        if gradient <= p.gradient_tolerance * self.initial_gradient:
            return (Status.CONVERGED, "gradient_tolerance", f"stationary: ‖Jᵀh‖∞ = {gradient:.1e} ≤ "
                    f"gradient_tolerance × its initial value; ‖h‖ = {norm:.3e}")
        if it == p.max_iterations:
            return Status.MAX_ITERATIONS, "max_iterations", f"reached {p.max_iterations} iterations with ‖h‖ = {norm:.3e}"
        if lam > p.lambda_max:
            return (Status.STALLED, "lambda_max", f"λ = {lam:.3e} exceeded lambda_max: no decrease of ‖h‖ = "
                    f"{norm:.3e} found (local minimum?)")
        return None

    def spent(self, it: int, norm: float) -> tuple[Status, str, str] | None:
        """The iteration budget spent after `it` iterations: at an accepted point the budget ends,
        `at_point`'s gradient test would need a Jacobian no step uses."""
        p = self.params
        if it >= p.max_iterations:
            return Status.MAX_ITERATIONS, "max_iterations", f"reached {p.max_iterations} iterations with ‖h‖ = {norm:.3e}"
        return None

    def after_step(self, norm: float, v: np.ndarray, decrease: float) -> tuple[Status, str, str] | None:
        stop = self._within_tolerance(norm, np.where(self.hinged, np.maximum(v, 0.0), v))
        if stop:
            return stop
        if decrease < self.params.function_tolerance:
            return (Status.CONVERGED, "function_tolerance", f"step lowered ‖h‖² by {decrease:.1e} < "
                    f"function_tolerance = {self.params.function_tolerance:.1e}; ‖h‖ = {norm:.3e}")
        return None

    def _within_tolerance(self, norm: float, h: np.ndarray) -> tuple[Status, str, str] | None:
        """‖h‖ or every row |h_i| within tolerance."""
        if norm < self.params.tolerance:
            return Status.CONVERGED, "tolerance", f"‖h‖ = {norm:.3e} < tolerance = {self.params.tolerance:.1e}"
        if self.row_tolerance is not None and np.all(np.abs(h) <= self.row_tolerance):
            return Status.CONVERGED, "row_tolerance", f"every row within its tolerance (‖h‖ = {norm:.3e})"
        return None


def _past(deadline: float | None) -> tuple[Status, str, str] | None:
    """The time-limit stop once the CPU clock has passed `deadline` (None: no deadline)."""
    if deadline is None or time.process_time() < deadline:
        return None
    return Status.TIME_LIMIT, "deadline", "CPU time budget spent"


GEODESIC_PROBE = 0.1  # h of the finite-difference second directional derivative (Transtrum & Sethna)


class _HingeModel:
    """The hinge model at one linearization (module docstring), in Marquardt-scaled variables.

    A pass factorizes J_Rᵀ J_R + λI for the rows R of the plain and active hinged rows by CHOLMOD's
    AAᵀ mode from those rows of J themselves (`CholmodSolver.set_jacobian` with `rows`): the symbolic
    analysis of the full J's pattern holds for every subset of its rows, so a linearization costs no
    product in Python. Later passes update the factor by the rows that changed (`refactor_rows`), and
    a pass whose active set is the last factorized one reuses its factorization and candidate."""

    def __init__(self, J, v: np.ndarray, hinged: np.ndarray, n: int, held: np.ndarray | None = None, rows=None,
                 expansion: _RowExpansion | None = None):
        J = J if type(J) is sp.csr_matrix else sp.csr_matrix(J)
        self.rows = rows
        if rows is None:
            d2 = np.bincount(J.indices, weights=J.data ** 2, minlength=n)
        else:  # over J_full's entries in its order: a shared row once per residual row it stands for
            take, indices = (expansion or _RowExpansion()).of(J, rows[0])
            d2 = np.bincount(indices, weights=J.data[take] ** 2, minlength=n)
        self.scale = np.where(d2 > MARQUARDT_FLOOR * d2.max(initial=0.0), 1.0 / np.sqrt(np.where(d2 > 0, d2, 1.0)), 1.0)
        if held is not None:  # a zero column and a zero scale: the step leaves these variables where they are
            self.scale[held] = 0.0
        Js = wrapped(sp.csr_matrix, J.data * self.scale[J.indices], J.indices, J.indptr, J.shape)
        self.J, self.v, self.hinged = Js, v, hinged

    def step(self, solver, lam: float, iterations: int, timings: Timings) -> np.ndarray | None:
        """Minimizer of the damped model by the active-set loop; None if a factorization fails."""
        hinged, v = self.hinged, self.v
        active = hinged & (v > 0)
        step, model_v = np.zeros(self.J.shape[1]), v.copy()
        factored = None  # the active set of the solver's factorization
        for _ in range(iterations):
            if factored is None or not np.array_equal(active, factored):
                t0 = time.perf_counter()
                rows = np.flatnonzero(~hinged | active)
                gradient = self._transposed_product(rows, v)
                keys, rows = (None, rows) if self.rows is None else (rows, self.rows[0][rows])  # J's rows
                t1 = time.perf_counter()
                timings.assemble += t1 - t0
                try:
                    if factored is None:
                        solver.set_jacobian(self.J, rows, keys)
                        solver.refactor(lam)
                    else:  # the same J and λ: few rows change from pass to pass
                        solver.refactor_rows(self.J, rows, keys)
                except NotPositiveDefiniteError:
                    timings.factorize += time.perf_counter() - t1
                    return None
                t2 = time.perf_counter()
                timings.factorize += t2 - t1
                candidate = -solver.solve(gradient)
                timings.solve += time.perf_counter() - t2
                factored = active
            direction = candidate - step
            change = _times(self.J, direction, self.rows)
            t = _model_line_search(model_v, change, hinged, lam, step, direction)
            if t == 0.0:
                break
            step, model_v = step + t * direction, model_v + t * change
            now = hinged & (model_v > 0)
            if t == 1.0 and np.array_equal(now, active):
                break
            active = now
        self.active = active  # at the step's end (the factorized set, unless the passes ran out)
        return step

    def rows_read(self) -> np.ndarray:
        """The rows (bool) whose values `acceleration` reads: the plain and active ones of the last step."""
        return ~self.hinged | self.active

    def acceleration(self, solver, difference: np.ndarray, h: float) -> np.ndarray:
        """Geodesic acceleration a = −(JᵀJ + λI)⁻¹ Jᵀ r_vv (scaled variables) of the last step, with
        r_vv ≈ (2/h)·difference the second directional derivative of the plain and active rows
        (difference = (r(θ + h·d) − r(θ))/h − J d, read on `rows_read` alone); reuses the step's
        factorization."""
        rows = np.flatnonzero(self.rows_read())
        return -solver.solve(self._transposed_product(rows, 2.0 / h * difference))

    def _transposed_product(self, rows: np.ndarray, x: np.ndarray) -> np.ndarray:
        """J_Rᵀ x_R for the rows R alone (the plain and active rows, a small part of J): the same sums
        in the same order as Jᵀ x with x zero off R, without the pass over the other rows."""
        return _rows_transposed_times(self.J, rows, x, self.rows)


class _RowExpansion:
    """Where the entries of J_full = J[jrow] (`Problem.row_map`'s rows, a shared row once per residual
    row it stands for) sit in J's data, and their column indices: the entries of `J[jrow]` in its
    order, worked out once per pattern of J and kept while J's index arrays are the same objects (the
    reduced J of `Problem.nonzero_jacobian` shares them from linearization to linearization while
    its pattern holds), so the Marquardt scale's sum over J_full is one gather of J's values."""

    def __init__(self):
        self._key = None

    def of(self, J: sp.csr_matrix, jrow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(take, indices): J_full's data is J.data[take], its column indices `indices`."""
        key = (J.indptr, J.indices, jrow)
        if self._key is None or any(a is not b for a, b in zip(self._key, key)) or J.indices.flags.writeable:
            count = np.diff(J.indptr)[jrow].astype(np.int64)
            start = np.repeat(J.indptr[jrow].astype(np.int64) - np.concatenate(([0], np.cumsum(count)[:-1])), count)
            self._take = start + np.arange(start.size)
            self._indices = J.indices[self._take]
            self._key = key
        return self._take, self._indices


def held_at_bounds(layout, theta: np.ndarray, J, v: np.ndarray, hinged: np.ndarray, rows=None) -> np.ndarray | None:
    """The variables on a bound of their box that the descent direction −Jᵀh points out of (None
    when no variable has a bound): a step keeps them there and the others take the model's step
    for the free variables alone (module docstring; Voglis and Lagaris's dogbox does the same).
    `rows`: the problem's `row_map` (None: J's rows are the residual rows)."""
    if not layout.bounded:
        return None
    gradient = _transposed_times(J, np.where(hinged, np.maximum(v, 0.0), v), rows)
    return ((theta <= layout.lower) & (gradient > 0.0)) | ((theta >= layout.upper) & (gradient < 0.0))


def _times(J, d: np.ndarray, rows) -> np.ndarray:
    """J_full d for J_full = diag(sign)·J[jrow] (`rows` = (jrow, sign) of `Problem.row_map`), or J d."""
    product = times(J, d)
    return product if rows is None else rows[1] * product[rows[0]]


def _rows_transposed_times(J, picked: np.ndarray, x: np.ndarray, rows) -> np.ndarray:
    """J_full[R]ᵀ x[R] for the residual rows R = `picked` (increasing): J[jrow[R]]ᵀ (sign·x)[R], each
    term ±(a·x) as J_full's, summed in R's order (`rows` as `_times`; None: J[R]ᵀ x[R])."""
    if rows is None:
        return J[picked].T @ x[picked]
    return J[rows[0][picked]].T @ (rows[1][picked] * x[picked])


def _transposed_times(J, x: np.ndarray, rows) -> np.ndarray:
    """J_fullᵀ x (`rows` as `_times`; None: Jᵀ x): over the rows where x is not zero, the terms a zero
    adds leaving every sum as it is."""
    if rows is None:
        return J.T @ x
    return _rows_transposed_times(J, np.flatnonzero(x != 0.0), x, rows)


def _model_line_search(a: np.ndarray, b: np.ndarray, hinged: np.ndarray, lam: float, d: np.ndarray,
                       p: np.ndarray) -> float:
    """argmin over t ∈ [0, 1] of the model along d + t·p: φ(t) = Σ_plain (a + tb)² + Σ_hinged max(0,
    a + tb)² + λ‖d + tp‖² with a = v + Jd, b = Jp. φ is convex and its derivative piecewise linear
    and nondecreasing; between the hinges' breakpoints t_i = −a_i/b_i it is A_k + t·B_k, updated as
    rows switch on (b_i > 0) or off (b_i < 0), so the root is found in one sorted pass."""
    on = ~hinged | (a > 0) | ((a == 0) & (b > 0))
    A0 = float(b[on] @ a[on]) + lam * float(p @ d)
    B0 = float(b[on] @ b[on]) + lam * float(p @ p)
    if A0 >= 0.0:
        return 0.0
    crossing = hinged & (b != 0)
    t = np.where(crossing, -a / np.where(crossing, b, 1.0), -1.0)
    inside = np.flatnonzero((t > 0.0) & (t < 1.0))
    order = inside[np.argsort(t[inside], kind="stable")]
    sign = np.sign(b[order])
    A = A0 + np.concatenate(([0.0], np.cumsum(sign * b[order] * a[order])))
    B = B0 + np.concatenate(([0.0], np.cumsum(sign * b[order] ** 2)))
    lo = np.concatenate(([0.0], t[order]))
    hi = np.concatenate((t[order], [1.0]))
    reached = np.flatnonzero(A + hi * B >= 0.0)
    if not reached.size:
        return 1.0
    k = reached[0]
    return float(min(max(lo[k], -A[k] / B[k]), hi[k])) if B[k] > 0 else float(lo[k])
