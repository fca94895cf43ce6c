"""Levenberg-Marquardt exactly as SolveLM of Algorithm 1, with the damping strategy of Table I.

Each iteration solves eq. (13), (JᵀJ + λI) Δθ = −Jᵀh, and accepts θ + Δθ only if ‖h‖ decreases;
λ ← λ·λ_drop after a success, λ ← λ·λ_boost after a failure (including a factorisation that is not
positive definite). It stops when ‖h‖ < ε_num (converged) or after MaxIt iterations, and also when
the step becomes negligible or λ exceeds `lambda_max` (stalled at a local minimum of ‖h‖).

Sign: the paper writes Δθ = (JᵀJ + λI)⁻¹Jᵀh and adds it; the descent step for ‖h‖² is the
negative of that, which is what is computed here.

A trial point is evaluated without Jacobians and, by default (`early_reject`), only until its
partial ‖h‖ reaches the current ‖h‖ (`Problem.trial_norm`): the decision of line 5, and so every
iterate, is the same as with the full residual, but most rejected points cost a fraction of it.
An accepted point is linearised (Jacobians, eq. (13)) only if another iteration follows: not after
the step that meets ε_num, nor at MaxIt; the norm reported then is that of the accepted trial point.

Options beyond the paper: ``assembly="jacobian"`` (eq. (13) factorised from J by CHOLMOD, JᵀJ
never formed in Python; see `Problem.normal_equations`), Marquardt scaling (λ·diag(JᵀJ) instead
of λI, applied as a column scaling so CHOLMOD's beta = λ refactorisation still applies),
projection onto box bounds, and Schur elimination of variables declared with
`VariableBlock.schur_block`.
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from legplan.solve.linsolve import SOLVER_NAMES, NotPositiveDefiniteError, make_solver
from legplan.solve.problem import ASSEMBLY_MODES, Problem
from legplan.solve.schur import SchurSolver

log = logging.getLogger(__name__)

MARQUARDT_FLOOR = 1e-14  # relative: diagonal entries of JᵀJ below this times the largest are not scaled


class Status(enum.Enum):
    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    STALLED = "stalled"
    NUMERICAL_FAILURE = "numerical_failure"


@dataclass(frozen=True)
class LMParams:
    """Parameters of SolveLM; defaults are Table I of the Bézier step-planning paper."""

    lambda_init: float = 1.0
    lambda_drop: float = 0.1
    lambda_boost: float = 1.5
    max_iterations: int = 100  # MaxIt
    tolerance: float = 1e-10  # ε_num: converged when ‖h‖ < tolerance
    step_tolerance: float = 1e-12  # stalled when ‖Δθ‖ < step_tolerance·(‖θ‖ + step_tolerance); 0 = off
    lambda_max: float = 1e12  # stalled when λ exceeds this
    lambda_min: float = 1e-20  # floor for λ so that λ_drop can never make it exactly zero
    marquardt_scaling: bool = False  # damp with λ·diag(JᵀJ) instead of λI
    linear_solver: str = "cholmod"  # "cholmod" | "scipy" | "dense"
    cholmod_mode: str = "simplicial"  # "simplicial" | "supernodal"
    assembly: str = "blocks"  # "blocks" (structured) | "stacked" (general) | "jacobian" (no JᵀJ formed)
    schur: bool = True  # eliminate variables that declare schur_block
    early_reject: bool = True  # stop evaluating a trial point once its partial ‖h‖ ≥ current ‖h‖ (same iterates)
    stall_window: int = 0  # opt-in stall stop (not Algorithm 1; 0 = off), see `solve_lm`

    def __post_init__(self):
        if not (0 < self.lambda_drop < 1 < self.lambda_boost):
            raise ValueError("need 0 < lambda_drop < 1 < lambda_boost")
        if self.stall_window < 0:
            raise ValueError("need stall_window ≥ 0")
        if self.lambda_init <= 0 or self.max_iterations < 0:
            raise ValueError("need lambda_init > 0 and max_iterations ≥ 0")
        if self.linear_solver not in SOLVER_NAMES:
            raise ValueError(f"linear_solver must be one of {SOLVER_NAMES}")
        if self.assembly not in ASSEMBLY_MODES:
            raise ValueError(f"assembly must be one of {ASSEMBLY_MODES}")


@dataclass
class Timings:
    """Wall time in seconds spent in each part of SolveLM."""

    evaluate: float = 0.0  # residual blocks: values and Jacobians (incl. trial points)
    assemble: float = 0.0  # stacking J / forming JᵀJ and Jᵀh
    factorize: float = 0.0  # (Schur reduction +) numeric factorisation
    solve: float = 0.0  # triangular solves
    total: float = 0.0


@dataclass
class LMResult:
    """Outcome of SolveLM: where it ended, why, and what it cost."""

    theta: np.ndarray
    values: dict[str, np.ndarray]
    status: Status
    reason: str
    iterations: int
    norm: float
    initial_norm: float
    norm_history: list[float] = field(default_factory=list)  # ‖h‖ after each iteration
    lambda_history: list[float] = field(default_factory=list)  # λ after each iteration
    accepted_steps: int = 0
    rejected_steps: int = 0
    timings: Timings = field(default_factory=Timings)

    @property
    def success(self) -> bool:
        return self.status is Status.CONVERGED


def solve_lm(problem: Problem, params: LMParams = LMParams(), theta0: np.ndarray | None = None,
             callback: Callable[[int, float, float], None] | None = None) -> LMResult:
    """Minimise ‖h(θ)‖ by SolveLM (Algorithm 1) from θ0 (default: the variable blocks' values).

    `callback(iteration, norm, lam)` is called after every iteration. The variable blocks are not
    modified; use `problem.layout.store(result.theta)` to write the solution back.

    Opt-in stall stop (`params.stall_window` = W > 0, a departure from Algorithm 1): after each
    iteration, extrapolate the decrease of ‖h‖ over the last W iterations geometrically; if at that
    rate ‖h‖ < ε_num would need more iterations than remain before MaxIt, stop with STALLED.
    """
    t_start = time.perf_counter()
    layout = problem.layout
    timings = Timings()
    theta = layout.initial() if theta0 is None else layout.project(np.array(theta0, float))
    solver = make_solver(params.linear_solver, params.cholmod_mode)
    schur = layout.schur_columns() if params.schur else None
    if schur is not None:
        solver = SchurSolver(solver, *schur)

    def finish(status, reason, it, norm, initial, hist_h, hist_l, accepted, rejected):
        timings.total = time.perf_counter() - t_start
        log.info("SolveLM %s after %d iterations: ‖h‖=%.3e (%s)", status.value, it, norm, reason)
        return LMResult(theta, layout.values(theta), status, reason, it, norm, initial, hist_h, hist_l,
                        accepted, rejected, timings)

    lam = params.lambda_init
    hist_h: list[float] = []
    hist_l: list[float] = []
    accepted = rejected = 0
    linearization = None
    norm = initial = np.inf
    for it in range(params.max_iterations + 1):
        # no linearisation where the loop stops anyway (see the module docstring)
        if linearization is None and (it == 0 or (norm >= params.tolerance and it < params.max_iterations)):
            linearization = problem.normal_equations(theta, params.assembly)
            timings.evaluate += linearization.evaluate_seconds
            timings.assemble += linearization.assemble_seconds
            norm = float(np.linalg.norm(linearization.residual))
            if it == 0:
                initial = norm
            from_jacobian = linearization.hessian is None  # assembly="jacobian": the solver forms JᵀJ
            matrix = linearization.jacobian if from_jacobian else linearization.hessian
            if not np.isfinite(norm) or not np.all(np.isfinite(matrix.data)):
                return finish(Status.NUMERICAL_FAILURE, "residual or Jacobian not finite at the current point",
                              it, norm, initial, hist_h, hist_l, accepted, rejected)
            matrix, g, scale = _damping_system(matrix, linearization.gradient, params.marquardt_scaling, from_jacobian)
            matrix_set = False
        if norm < params.tolerance:
            return finish(Status.CONVERGED, f"‖h‖ = {norm:.3e} < ε_num = {params.tolerance:.1e}",
                          it, norm, initial, hist_h, hist_l, accepted, rejected)
        if it == params.max_iterations:
            return finish(Status.MAX_ITERATIONS, f"reached MaxIt = {params.max_iterations} with ‖h‖ = {norm:.3e}",
                          it, norm, initial, hist_h, hist_l, accepted, rejected)
        if lam > params.lambda_max:
            return finish(Status.STALLED, f"λ = {lam:.3e} exceeded lambda_max = {params.lambda_max:.1e}: "
                          f"no decrease of ‖h‖ = {norm:.3e} found (local minimum?)",
                          it, norm, initial, hist_h, hist_l, accepted, rejected)
        step = None
        t0 = time.perf_counter()
        try:
            if not matrix_set:  # once per linearisation; a rejected step only refactors at the new λ
                if from_jacobian:
                    solver.set_jacobian(matrix)
                else:
                    solver.set_matrix(matrix)
                matrix_set = True
            solver.refactor(lam)
            t1 = time.perf_counter()
            timings.factorize += t1 - t0
            step = -solver.solve(g) if scale is None else -scale * solver.solve(scale * g)
            timings.solve += time.perf_counter() - t1
        except NotPositiveDefiniteError as exc:
            timings.factorize += time.perf_counter() - t0
            log.debug("iteration %d: factorisation failed at λ=%.3e (%s); raising λ", it + 1, lam, exc)
        if step is not None and np.all(np.isfinite(step)):
            trial = layout.project(theta + step)
            taken = trial - theta
            if np.linalg.norm(taken) < params.step_tolerance * (np.linalg.norm(theta) + params.step_tolerance):
                return finish(Status.STALLED, f"step ‖Δθ‖ = {np.linalg.norm(taken):.3e} below step_tolerance "
                              f"relative to ‖θ‖ at λ = {lam:.3e}; ‖h‖ = {norm:.3e}",
                              it, norm, initial, hist_h, hist_l, accepted, rejected)
            t0 = time.perf_counter()
            if params.early_reject:  # only the accept/reject decision needs ‖h(trial)‖ vs ‖h‖
                trial_norm = problem.trial_norm(trial, norm)
            else:
                trial_norm = float(np.linalg.norm(problem.residual(trial)))
            timings.evaluate += time.perf_counter() - t0
        else:
            trial_norm = np.inf
        if trial_norm < norm:  # Algorithm 1, lines 5-7
            theta = trial
            lam = max(lam * params.lambda_drop, params.lambda_min)
            linearization = None
            accepted += 1
            norm = trial_norm
        else:  # Algorithm 1, line 9
            lam *= params.lambda_boost
            rejected += 1
        hist_h.append(norm)
        hist_l.append(lam)
        log.debug("iteration %d: ‖h‖=%.6e λ=%.3e %s", it + 1, norm, lam, "accepted" if linearization is None else "rejected")
        if callback is not None:
            callback(it + 1, norm, lam)
        if params.stall_window and len(hist_h) > params.stall_window:
            past = hist_h[-1 - params.stall_window]
            remaining = params.max_iterations - (it + 1)
            if remaining > 0 and norm >= params.tolerance and _out_of_reach(norm, past, params, remaining):
                return finish(Status.STALLED, f"‖h‖ went from {past:.3e} to {norm:.3e} over the last "
                              f"{params.stall_window} iterations: ε_num = {params.tolerance:.1e} out of reach "
                              f"within the {remaining} iterations left at that rate (stall_window)",
                              it + 1, norm, initial, hist_h, hist_l, accepted, rejected)
    raise AssertionError("unreachable: the loop returns at it == max_iterations")


def _out_of_reach(norm: float, past: float, params: LMParams, remaining: int) -> bool:
    """Whether the geometric rate (norm/past)^(1/W) needs more than `remaining` iterations to ε_num."""
    if norm >= past:
        return True
    needed = params.stall_window * np.log(params.tolerance / norm) / np.log(norm / past)
    return needed > remaining


def _damping_system(M: sp.spmatrix, g: np.ndarray, marquardt: bool, jacobian: bool):
    """M, g and column scale s such that the step is −s·(s H s + λI)⁻¹ (s g), where M is H, or J
    (CSR, H = JᵀJ) when `jacobian`; the returned M is then s H s, or J·diag(s).

    With Marquardt scaling s = diag(H)^(-1/2) (1 on columns whose diagonal is below `MARQUARDT_FLOOR`
    times the largest: no information there, and a round-off diagonal must not blow the step up), which is (H + λ diag(H))⁻¹ in the original
    variables; otherwise s = 1 (returned as None) and this is eq. (13) as written.
    """
    if not marquardt:
        return M, g, None
    d = np.bincount(M.indices, weights=M.data ** 2, minlength=g.size) if jacobian else M.diagonal()
    s = np.ones_like(d)
    positive = d > MARQUARDT_FLOOR * d.max(initial=0.0)  # a round-off diagonal would give a huge scale
    s[positive] = 1.0 / np.sqrt(d[positive])
    Ms = M.copy()
    Ms.data *= s[Ms.indices] if jacobian else s[Ms.indices] * np.repeat(s, np.diff(Ms.indptr))
    return Ms, g, s
