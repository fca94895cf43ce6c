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
`VariableBlock.schur_block` (for one structured block without Marquardt scaling, eq. (13) reaches the
Schur solver as its dense pieces, `Problem.normal_equations(schur=…)`; the steps are those of the
assembled H bit for bit).
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from legplan.solve.linsolve import SOLVER_NAMES, LinearSolver, NotPositiveDefiniteError, make_solver
from legplan.solve.problem import ASSEMBLY_MODES, Problem, SchurParts
from legplan.solve.schur import SchurSolver

log = logging.getLogger(__name__)

MARQUARDT_FLOOR = 1e-14  # relative: diagonal entries of JᵀJ below this times the largest are not scaled


class Status(enum.Enum):
    """Why a solver stopped (`LMResult.status`, `legplan.solve.auglag.ALResult.status`)."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    STALLED = "stalled"
    NUMERICAL_FAILURE = "numerical_failure"
    TIME_LIMIT = "time_limit"  # a CPU deadline passed (`solve_hinged_lm`'s `deadline`): stopped at the point reached


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
    stopped_by: str = ""  # the parameter whose test stopped it ("tolerance", "max_iterations", ...), where known

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
    theta = layout.initial() if theta0 is None else layout.project(np.array(theta0, float))
    state = _LMState(problem, params, theta, params.lambda_init, t_start)
    solver = make_solver(params.linear_solver, params.cholmod_mode)
    schur = layout.schur_columns() if params.schur else None
    if schur is not None:
        solver = SchurSolver(solver, *schur)
        # H as the Schur pieces straight from a structured block (`Problem.normal_equations`), where the
        # reduced system is dense and unscaled: the same steps without a sparse H
        if not params.marquardt_scaling and (layout.n - schur[0].size) * schur[0].size <= solver.dense_limit:
            state.schur_parts = schur
    system = None
    while True:
        if system is None and state.must_linearize():
            system = _linearize(state)
            if system is None:
                return state.result(Status.NUMERICAL_FAILURE, "residual or Jacobian not finite at the current point")
        stop = _stop_before_step(state)
        if stop is not None:
            return state.result(*stop)
        step = _damped_step(solver, system, state)
        trial_norm, trial = np.inf, None
        if step is not None:
            trial = layout.project(state.theta + step)
            stop = _negligible_step(state, trial)
            if stop is not None:
                return state.result(*stop)
            trial_norm = _trial_norm(state, trial)
        if state.accept_or_reject(trial, trial_norm):
            system = None
        if callback is not None:
            callback(state.iterations, state.norm, state.lam)
        stop = _stall_window_stop(state)
        if stop is not None:
            return state.result(*stop)


@dataclass
class _LMState:
    """What one `solve_lm` run carries from iteration to iteration, and the `LMResult` made of it."""

    problem: Problem
    params: LMParams
    theta: np.ndarray
    lam: float
    t_start: float  # perf_counter at the call, for Timings.total
    norm: float = np.inf  # ‖h(θ)‖
    initial: float = np.inf  # ‖h(θ0)‖
    norm_history: list[float] = field(default_factory=list)
    lambda_history: list[float] = field(default_factory=list)
    accepted: int = 0
    rejected: int = 0
    timings: Timings = field(default_factory=Timings)
    schur_parts: tuple[np.ndarray, int] | None = None  # ask `normal_equations` for H as `SchurParts`

    @property
    def iterations(self) -> int:
        """Iterations finished so far (one history entry each)."""
        return len(self.norm_history)

    def must_linearize(self) -> bool:
        """Whether the point needs its Jacobians: always at the start, else only if the loop goes on."""
        it = self.iterations
        return it == 0 or (self.norm >= self.params.tolerance and it < self.params.max_iterations)

    def accept_or_reject(self, trial: np.ndarray | None, trial_norm: float) -> bool:
        """Algorithm 1, lines 5-9: move to `trial` and drop λ if ‖h‖ decreases, else raise λ.

        Records the iteration in the histories; returns whether the step was accepted.
        """
        accepted = trial_norm < self.norm
        if accepted:
            self.theta = trial
            self.lam = max(self.lam * self.params.lambda_drop, self.params.lambda_min)
            self.accepted += 1
            self.norm = trial_norm
        else:
            self.lam *= self.params.lambda_boost
            self.rejected += 1
        self.norm_history.append(self.norm)
        self.lambda_history.append(self.lam)
        log.debug("iteration %d: ‖h‖=%.6e λ=%.3e %s", self.iterations, self.norm, self.lam,
                  "accepted" if accepted else "rejected")
        return accepted

    def result(self, status: Status, reason: str) -> LMResult:
        """The outcome at the current point, ending the run's clock."""
        self.timings.total = time.perf_counter() - self.t_start
        log.info("SolveLM %s after %d iterations: ‖h‖=%.3e (%s)", status.value, self.iterations, self.norm, reason)
        return LMResult(self.theta, self.problem.layout.values(self.theta), status, reason, self.iterations,
                        self.norm, self.initial, self.norm_history, self.lambda_history, self.accepted,
                        self.rejected, self.timings)


@dataclass
class _DampedSystem:
    """Eq. (13) at one linearisation, as `_damping_system` returns it, loaded into the solver once."""

    matrix: sp.spmatrix | SchurParts  # (scaled) JᵀJ, or (scaled) J when `from_jacobian`, or JᵀJ's Schur pieces
    gradient: np.ndarray
    scale: np.ndarray | None
    from_jacobian: bool
    loaded: bool = False  # set into the solver; a rejected step only refactors at the new λ


def _linearize(state: _LMState) -> _DampedSystem | None:
    """Jacobians and eq. (13) at the current point, updating ‖h‖; None if anything is not finite."""
    if state.schur_parts is None:
        linearization = state.problem.normal_equations(state.theta, state.params.assembly)
    else:
        linearization = state.problem.normal_equations(state.theta, state.params.assembly, schur=state.schur_parts)
    state.timings.evaluate += linearization.evaluate_seconds
    state.timings.assemble += linearization.assemble_seconds
    state.norm = float(np.linalg.norm(linearization.residual))
    if state.iterations == 0:
        state.initial = state.norm
    parts = linearization.schur_parts
    if parts is not None:  # no scaling: asked for only without Marquardt scaling
        if not np.isfinite(state.norm) or not parts.finite():
            return None
        return _DampedSystem(parts, linearization.gradient, None, False)
    from_jacobian = linearization.hessian is None  # assembly="jacobian": the solver forms JᵀJ
    matrix = linearization.jacobian if from_jacobian else linearization.hessian
    if not np.isfinite(state.norm) or not np.all(np.isfinite(matrix.data)):
        return None
    matrix, g, scale = _damping_system(matrix, linearization.gradient, state.params.marquardt_scaling, from_jacobian)
    return _DampedSystem(matrix, g, scale, from_jacobian)


def _stop_before_step(state: _LMState) -> tuple[Status, str] | None:
    """Converged, MaxIt reached or λ beyond `lambda_max`: the status and reason, else None."""
    params, norm = state.params, state.norm
    if norm < params.tolerance:
        return Status.CONVERGED, f"‖h‖ = {norm:.3e} < ε_num = {params.tolerance:.1e}"
    if state.iterations == params.max_iterations:
        return Status.MAX_ITERATIONS, f"reached MaxIt = {params.max_iterations} with ‖h‖ = {norm:.3e}"
    if state.lam > params.lambda_max:
        return Status.STALLED, (f"λ = {state.lam:.3e} exceeded lambda_max = {params.lambda_max:.1e}: "
                                f"no decrease of ‖h‖ = {norm:.3e} found (local minimum?)")
    return None


def _damped_step(solver: LinearSolver, system: _DampedSystem, state: _LMState) -> np.ndarray | None:
    """Δθ of eq. (13) at the current λ; None if the factorisation fails or the step is not finite."""
    timings = state.timings
    t0 = time.perf_counter()
    try:
        if not system.loaded:
            if isinstance(system.matrix, SchurParts):
                solver.set_parts(system.matrix)
            elif system.from_jacobian:
                solver.set_jacobian(system.matrix)
            else:
                solver.set_matrix(system.matrix)
            system.loaded = True
        solver.refactor(state.lam)
        t1 = time.perf_counter()
        timings.factorize += t1 - t0
        g, scale = system.gradient, system.scale
        step = -solver.solve(g) if scale is None else -scale * solver.solve(scale * g)
        timings.solve += time.perf_counter() - t1
    except NotPositiveDefiniteError as exc:
        timings.factorize += time.perf_counter() - t0
        log.debug("iteration %d: factorisation failed at λ=%.3e (%s); raising λ", state.iterations + 1, state.lam, exc)
        return None
    return step if np.all(np.isfinite(step)) else None


def _negligible_step(state: _LMState, trial: np.ndarray) -> tuple[Status, str] | None:
    """STALLED and its reason if the projected step to `trial` is below `step_tolerance`, else None."""
    tolerance = state.params.step_tolerance
    taken = _norm(trial - state.theta)
    if taken < tolerance * (_norm(state.theta) + tolerance):
        return Status.STALLED, (f"step ‖Δθ‖ = {taken:.3e} below step_tolerance relative to ‖θ‖ "
                                f"at λ = {state.lam:.3e}; ‖h‖ = {state.norm:.3e}")
    return None


def _norm(v: np.ndarray) -> float:
    """‖v‖ of a vector as `np.linalg.norm` forms it (√(v·v)), without its argument handling (twice per iteration)."""
    return float(np.sqrt(v.dot(v)))


def _trial_norm(state: _LMState, trial: np.ndarray) -> float:
    """‖h(trial)‖, or with `early_reject` any value ≥ ‖h‖ once the partial sum reaches it."""
    t0 = time.perf_counter()
    if state.params.early_reject:  # only the accept/reject decision needs ‖h(trial)‖ vs ‖h‖
        trial_norm = state.problem.trial_norm(trial, state.norm)
    else:
        trial_norm = float(np.linalg.norm(state.problem.residual(trial)))
    state.timings.evaluate += time.perf_counter() - t0
    return trial_norm


def _stall_window_stop(state: _LMState) -> tuple[Status, str] | None:
    """STALLED and its reason if `stall_window` says ε_num is out of reach before MaxIt, else None."""
    params, history = state.params, state.norm_history
    if not params.stall_window or len(history) <= params.stall_window:
        return None
    past, norm = history[-1 - params.stall_window], state.norm
    remaining = params.max_iterations - state.iterations
    if remaining > 0 and norm >= params.tolerance and _out_of_reach(norm, past, params, remaining):
        return Status.STALLED, (f"‖h‖ went from {past:.3e} to {norm:.3e} over the last {params.stall_window} "
                                f"iterations: ε_num = {params.tolerance:.1e} out of reach within the "
                                f"{remaining} iterations left at that rate (stall_window)")
    return None


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
