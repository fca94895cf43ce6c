"""Benchmark of the centroidal optimizer (`legplan.dyn`) against TOWR's figures and Ipopt (issue 14).

    .venv/bin/python bench/dyn.py [--quick] [--repeats 5] [--ipopt-repeats 3] [--ipopt-max-cpu 40]
                                  [--cases KEY,KEY] [--ipopt-scaled] [--skip-ipopt] [--skip-costs]
                                  [--skip-table-one] [--no-append] [--render]

Side by side in one process, on TOWR's cases (issue 14's table) plus stairs:

* ours: `legplan.dyn.planner.plan` with `DynParams()` (no costs: TOWR's feasibility problem), from
  the heuristic initializer. CPU seconds (`time.process_time`) of the solve (every call of
  `solve_augmented_lagrangian`, all stages) and of the set-up (problem builds and the 10 ms sampling:
  the rest of `plan`) separately; median of `--repeats` runs (3 for a case whose first run takes
  more than `CHEAP` s). Iterations are LM iterations (each one CHOLMOD factorization), over all stages.
* Ipopt on the same formulation: x = the free entries of `build_problem(...)`'s variables (same
  heuristic start), objective Σ ½·w·‖r‖² of its cost blocks with gradient Σ w·Jᵀr, constraints =
  the stacked constraint blocks with their lower/upper bounds, in the blocks' own units (N, N·m, m)
  as TOWR hands them to Ipopt (`--ipopt-scaled` multiplies the rows by our solver-side row scales
  instead); sparse constraint Jacobian with one fixed structure (the union of the blocks' patterns).
  Options as TOWR's: MUMPS, L-BFGS Hessian ("limited-memory"), tol 1e-3, max_cpu_time 40 s. When
  our planner dropped TOWR's swing constraint (its stage 2), Ipopt gets the formulation without it
  too (the one our answer satisfies). CPU seconds of `solve()` (its callbacks into our blocks
  included, as our solve includes them), iterations from Ipopt's intermediate callback, success =
  Ipopt status 0 and our max violation ≤ 1e-3 at its answer.
* TOWR's figures as measured on this machine (issue 14: C++, Ipopt 3.11.9 + MUMPS, same settings)
  as the external reference column, and the ratios ours/TOWR, ours/Ipopt.
* Every answer (ours and Ipopt's) sampled every 10 ms and judged by the independent dense check
  `legplan.validate.trajectory.check_trajectory` (skipped, and said so, when it is not importable).
* With the paper's costs (`legplan.dyn.problem.PAPER`, or the issue's DynParams(costs=PAPER_COSTS,
  swing_height_min=0.05, base_clearance=0.3) when that preset does not exist) vs without on the
  pallet cases: cost terms (the paper's blocks evaluated at both answers), peak forces and peak base
  roll/pitch rates (the paper's Fig. 4).
* The paper's Table I: CPU time of the first and the mean iteration, No Phase (our planner) and
  No Phase&Feet (the ``feet`` variable fixed at the initializer's values, whose footholds the heuristic
  already puts at the terrain height: the paper's "adapting the height to the terrain"), with and
  without costs, on flat ground (walk 1.5 m / 3.5 s) and the single pallet (walk), and Full (the phase
  durations optimized too, `DynParams.optimize_phases`). First iteration = CPU of `solve_augmented_lagrangian` with
  an iteration budget of 1 from the initializer (set-up, CHOLMOD analysis and one LM step).

One BLAS thread. Writes bench/results/dyn.json and replaces the `dyn` section of BENCHMARKS.md;
`--quick` (1 run each, Ipopt capped at 10 s, no BENCHMARKS.md) writes bench/results/dyn_quick.json.
Ipopt is a bench-only dependency: `apt-get install -y coinor-libipopt-dev` (Debian's Ipopt 3.11.9
with MUMPS, TOWR's) then `.venv/bin/pip install -e '.[bench]'` (cyipopt, built against it).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import time
from dataclasses import replace

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy/scipy/Ipopt load BLAS

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from common import ROOT, code_version, machine, update_benchmarks, write_result  # noqa: E402
import legplan.dyn.planner as planner  # noqa: E402
from legplan.dyn.costs import CostWeights  # noqa: E402
from legplan.dyn.init import heuristic  # noqa: E402
from legplan.dyn.problem import DynParams, DynTask, build_problem  # noqa: E402
from legplan.dyn.terrain import TerrainModel  # noqa: E402
from legplan.robots import load_robot  # noqa: E402
from legplan.solve import VariableLayout  # noqa: E402
from legplan.solve.auglag import evaluate_costs, solve_augmented_lagrangian  # noqa: E402
from legplan.terrain import build_map  # noqa: E402

try:
    from legplan.dyn.problem import PAPER as PAPER_PARAMS  # the optimizer owner's preset
    PAPER_SOURCE = "legplan.dyn.problem.PAPER"
except ImportError:  # pragma: no cover - older trees
    from legplan.dyn.problem import PAPER_COSTS
    PAPER_PARAMS = DynParams(costs=PAPER_COSTS, swing_height_min=0.05, base_clearance=0.3)
    PAPER_SOURCE = "DynParams(costs=PAPER_COSTS, swing_height_min=0.05, base_clearance=0.3)"

try:
    from legplan.validate.trajectory import check_trajectory
except ImportError:  # not committed yet
    check_trajectory = None

try:
    import cyipopt
except ImportError:
    cyipopt = None

VIOLATION_TOL = 1e-3
CHEAP = 2.0  # s: a case whose first run of ours takes less gets --repeats runs, else 3
PENETRATION_TOL = 5e-3  # m, the "no foot more than 5 mm below the terrain"
FORCE_TOL = 1e-3  # relative, friction and force bounds

# TOWR's cases (issue 14), TOWR measured on this machine: vars, iterations, CPU s of the solve
CASES = [
    dict(key="flat_trot", label="flat trot 1.0 m / 2.4 s, 4 strides", map="flat", gait="trot", strides=4,
         duration=2.4, start=(0.0, 0.0, 0.0), goal=(1.0, 0.0, 0.0), towr=dict(vars=688, iterations=13, cpu=0.53)),
    dict(key="flat_walk", label="flat walk 1.5 m / 3.5 s, 4 strides", map="flat", gait="walk", strides=4,
         duration=3.5, start=(0.0, 0.0, 0.0), goal=(1.5, 0.0, 0.0), towr=dict(vars=860, iterations=19, cpu=0.97)),
    dict(key="single_walk", label="single pallet walk 5.5 s", map="single_pallet", gait="walk", strides=4,
         duration=5.5, start=(-1.0, 0.3, 0.3), goal=(0.6, 0.0, 0.0), towr=dict(vars=1100, iterations=13, cpu=1.27)),
    dict(key="single_trot", label="single pallet trot 5.5 s", map="single_pallet", gait="trot", strides=4,
         duration=5.5, start=(-1.2, -0.5, -0.4), goal=(0.6, 0.0, 0.0), towr=dict(vars=1060, iterations=42, cpu=4.55)),
    dict(key="double_walk", label="double pallet walk 5.5 s", map="double_pallet", gait="walk", strides=4,
         duration=5.5, start=(-1.0, 0.0, 0.0), goal=(1.0, 0.0, 0.0), towr=dict(vars=1100, iterations=34, cpu=3.00)),
    dict(key="flat_trot_2", label="flat trot 1.0 m / 2.4 s, 2 strides", map="flat", gait="trot", strides=2,
         duration=2.4, start=(0.0, 0.0, 0.0), goal=(1.0, 0.0, 0.0),
         towr=dict(vars=528, iterations=1001, cpu=40.0, failed=True, violation=0.96)),
    # Stairs (no TOWR figure): 4 steps of 15 cm rise / 30 cm run, goal on the landing. 6 walk strides
    # in 8.0 s give the pallet walks' stride timing (TOWR's walk stride scaled by the same 0.84) and
    # about their stride length (2.5 m / 6 = 0.42 m vs 1.6 m / 4 = 0.40 m).
    dict(key="stairs_walk", label="stairs walk 2.5 m / 8.0 s, 6 strides", map="stairs", gait="walk", strides=6,
         duration=8.0, start=(-0.8, 0.0, 0.0), goal=(1.7, 0.0, 0.0), towr=None),
]
PALLET_CASES = ("single_walk", "single_trot", "double_walk")
TABLE_ONE_CASES = (("Flat Ground", "flat_walk"), ("Pallets", "single_walk"))
PAPER_TABLE_ONE = {  # ms on the paper's onboard computer: (1st iter., mean) with costs [without]
    "Full": {"Flat Ground": ((315, 304), (156, 126)), "Pallets": ((843, 700), (417, 305))},
    "No Phase": {"Flat Ground": ((210, 202), (69, 60)), "Pallets": ((385, 371), (117, 108))},
    "No Phase&Feet": {"Flat Ground": ((282, 282), (84, 74)), "Pallets": ((534, 524), (177, 145))},
}


def task_of(case) -> DynTask:
    return DynTask(start=case["start"], goal=case["goal"], gait=case["gait"], strides=case["strides"],
                   duration=case["duration"])


# --- ours --------------------------------------------------------------------------------------------
class SolveClock:
    """CPU seconds spent inside `solve_augmented_lagrangian` during `planner.plan` (all its stages)."""

    def __init__(self):
        self.seconds = 0.0
        self._original = planner.solve_augmented_lagrangian

    def __enter__(self):
        def timed(*args, **kwargs):
            t0 = time.process_time()
            try:
                return self._original(*args, **kwargs)
            finally:
                self.seconds += time.process_time() - t0
        planner.solve_augmented_lagrangian = timed
        return self

    def __exit__(self, *exc):
        planner.solve_augmented_lagrangian = self._original


def plan_once(case, model, terrain: TerrainModel, params: DynParams):
    """One `plan` call: (result, total CPU s, solve CPU s)."""
    with SolveClock() as clock:
        t0 = time.process_time()
        result = planner.plan(task_of(case), model, terrain, params)
        total = time.process_time() - t0
    return result, total, clock.seconds


def run_ours(case, model, terrain, params, repeats: int):
    """Median over runs of ours on one case (3 runs at most when the first is not cheap); the last
    run's result is kept for the checks."""
    runs, result = [], None
    while len(runs) < repeats:
        result, total, solve = plan_once(case, model, terrain, params)
        runs.append((solve, total - solve))
        if len(runs) == 1 and solve > CHEAP:
            repeats = min(repeats, 3)
    s = result.solve
    layout = VariableLayout(result.problem.variables)
    return result, {
        "cpu_solve_s": statistics.median(r[0] for r in runs), "cpu_setup_s": statistics.median(r[1] for r in runs),
        "runs_solve_s": [r[0] for r in runs], "iterations": s.iterations, "outer_iterations": s.outer_iterations,
        "success": bool(s.success), "reason": s.reason, "max_violation": float(s.max_violation),
        "violations": {k: float(v) for k, v in s.violations.items()}, "variables": layout.n,
        "paper_variables": result.problem.form.paper_variable_count(), "footsteps": result.problem.form.footsteps,
        "towr_swing": has_towr_swing(result.problem),
        "first_iteration_wall_s": float(getattr(s, "first_iteration_seconds", float("nan")))}


def has_towr_swing(problem) -> bool:
    return any(k.name == "swing" for k in problem.constraints)


def dense_check(samples, model, terrain_map, robot, node_times):
    """The independent check's worst values (None when it is not available)."""
    if check_trajectory is None:
        return None
    try:
        c = check_trajectory(samples, model, terrain_map, robot, node_times=node_times)
    except Exception as exc:  # noqa: BLE001 - a crash of the check is a result to report, not a bench crash
        return {"error": f"{type(exc).__name__}: {exc}"}
    worst = {k: float(v) for k, v in c.worst.items()}
    penetration = max(worst["penetration_height"], worst["penetration_column"])
    force = max(worst["normal_force"], worst["friction_cone"])
    weight = model.mass * 9.81
    return {"ok": bool(c.ok), "failed": sorted(k for k, p in c.passed.items() if not p), "worst": worst,
            "penetration_m": penetration, "force_rel": force,
            "newton_euler_force_rel": worst["newton_euler_force"] / weight,
            "target_met": bool(penetration <= PENETRATION_TOL and force <= FORCE_TOL)}


# --- Ipopt on our formulation ------------------------------------------------------------------------
class IpoptNLP:
    """Our problem as a general NLP for cyipopt: x = free entries (VariableLayout columns),
    f = Σ ½ w ‖r‖², c = stacked constraint blocks (own units, or times their row scales if `scaled`)."""

    def __init__(self, problem, scaled: bool = False):
        self.layout = VariableLayout(problem.variables)
        self.costs, self.constraints_list = problem.costs, problem.constraints
        self.n = self.layout.n
        self.offsets = np.cumsum([0] + [k.block.size for k in self.constraints_list])
        self.m = int(self.offsets[-1])
        self.row_scale = (np.concatenate([k.scale for k in self.constraints_list]) if scaled else np.ones(self.m))
        self.lower = np.concatenate([k.lower for k in self.constraints_list]) * self.row_scale
        self.upper = np.concatenate([k.upper for k in self.constraints_list]) * self.row_scale
        x0 = self.layout.initial()
        # one fixed structure: the union of the blocks' patterns at the start and at a perturbed point
        keys = np.empty(0, np.int64)
        for x in (x0, x0 + 1e-3 * np.random.default_rng(0).standard_normal(self.n)):
            r, c, _ = self._triplets(x)
            keys = np.union1d(keys, r.astype(np.int64) * self.n + c)
        self.keys = keys
        self.rows, self.cols = (keys // self.n).astype(np.int32), (keys % self.n).astype(np.int32)
        self.scale_of_entry = self.row_scale[self.rows]
        self.iterations = 0
        self.evaluations = {"f": 0, "grad": 0, "c": 0, "jac": 0}
        self.callback_seconds = 0.0  # CPU s inside the callbacks below (our blocks, Python)
        for name in ("objective", "gradient", "constraints", "jacobian"):
            setattr(self, name, self._timed(getattr(self, name)))

    def _timed(self, fn):
        def timed(x):
            t0 = time.process_time()
            try:
                return fn(x)
            finally:
                self.callback_seconds += time.process_time() - t0
        return timed

    def _free(self, name, cols):
        col = self.layout.columns[name][cols]
        return col, col >= 0

    def _triplets(self, x):
        values = self.layout.values(x)
        R, C, D = [], [], []
        for k, start in zip(self.constraints_list, self.offsets[:-1]):
            _, jacs = k.block.evaluate([values[v] for v in k.block.variables], True)
            for name, jac in zip(k.block.variables, jacs):
                jac = sp.coo_matrix(jac)
                col, keep = self._free(name, jac.col)
                R.append(jac.row[keep] + start), C.append(col[keep]), D.append(jac.data[keep])
        return np.concatenate(R), np.concatenate(C), np.concatenate(D)

    # cyipopt callbacks
    def objective(self, x):
        self.evaluations["f"] += 1
        values = self.layout.values(x)
        return sum(evaluate_costs(self.costs, values).values())

    def gradient(self, x):
        self.evaluations["grad"] += 1
        values = self.layout.values(x)
        g = np.zeros(self.n)
        for term in self.costs:
            block, w = term.block, term.weight
            r, jacs = block.evaluate([values[v] for v in block.variables], True)
            for name, jac in zip(block.variables, jacs):
                gv = w * np.asarray(jac.T @ r).reshape(-1)
                col, keep = self._free(name, np.arange(gv.size))
                np.add.at(g, col[keep], gv[keep])
        return g

    def constraint_values(self, x):
        """Stacked constraint values in the blocks' own units."""
        values = self.layout.values(x)
        return np.concatenate([np.asarray(k.block.evaluate([values[v] for v in k.block.variables], False)[0], float)
                               for k in self.constraints_list])

    def constraints(self, x):
        self.evaluations["c"] += 1
        return self.constraint_values(x) * self.row_scale

    def jacobianstructure(self):
        return self.rows, self.cols

    def jacobian(self, x):
        self.evaluations["jac"] += 1
        r, c, d = self._triplets(x)
        keys = r.astype(np.int64) * self.n + c
        pos = np.searchsorted(self.keys, keys)
        bad = (pos >= self.keys.size) | (self.keys[np.minimum(pos, self.keys.size - 1)] != keys)
        if np.any(bad & (d != 0)):
            raise RuntimeError("constraint Jacobian entry outside the fixed structure")
        return np.bincount(pos[~bad], weights=d[~bad], minlength=self.keys.size) * self.scale_of_entry

    def intermediate(self, alg_mod, iter_count, *args):
        self.iterations = int(iter_count)
        return True

    def max_violation(self, x):
        c = self.constraint_values(x)
        per = {}
        for k, a, b in zip(self.constraints_list, self.offsets[:-1], self.offsets[1:]):
            if b > a:
                per[k.name] = max(per.get(k.name, 0.0), float(k.violation(c[a:b]).max()))
        return max(per.values(), default=0.0), per


IPOPT_OPTIONS = {"linear_solver": "mumps", "hessian_approximation": "limited-memory", "tol": 1e-3,
                 "jacobian_approximation": "exact", "print_level": 0, "sb": "yes"}


def ipopt_once(case, model, terrain, params, max_cpu: float, scaled: bool):
    t0 = time.process_time()
    problem = build_problem(task_of(case), model, terrain, params, heuristic)
    nlp = IpoptNLP(problem, scaled)
    solver = cyipopt.Problem(n=nlp.n, m=nlp.m, problem_obj=nlp, lb=nlp.layout.lower, ub=nlp.layout.upper,
                             cl=nlp.lower, cu=nlp.upper)
    for key, value in {**IPOPT_OPTIONS, "max_cpu_time": float(max_cpu)}.items():
        solver.add_option(key, value)
    x0 = nlp.layout.initial()
    setup = time.process_time() - t0
    t0 = time.process_time()
    x, info = solver.solve(x0)
    cpu = time.process_time() - t0
    violation, per = nlp.max_violation(x)
    status = int(info["status"])
    return problem, nlp, x, {
        "cpu_solve_s": cpu, "cpu_setup_s": setup, "iterations": nlp.iterations, "status": status,
        "status_msg": info["status_msg"].decode() if isinstance(info["status_msg"], bytes) else str(info["status_msg"]),
        "success": bool(status == 0 and violation <= VIOLATION_TOL), "max_violation": violation, "violations": per,
        "variables": nlp.n, "constraint_rows": nlp.m, "jacobian_nnz": int(nlp.keys.size),
        "evaluations": dict(nlp.evaluations), "callback_cpu_s": nlp.callback_seconds,
        "objective": float(info["obj_val"])}


def run_ipopt(case, model, terrain, params, repeats: int, max_cpu: float, scaled: bool):
    runs = []
    problem = nlp = x = row = None
    for i in range(repeats):
        problem, nlp, x, row = ipopt_once(case, model, terrain, params, max_cpu, scaled)
        runs.append(row["cpu_solve_s"])
        if row["cpu_solve_s"] > 5.0:  # slow (or failing at the CPU cap): one run is enough
            break
    row = dict(row, cpu_solve_s=statistics.median(runs), runs_solve_s=runs, towr_swing=params.towr_swing,
               callback_share=row["callback_cpu_s"] / max(row["cpu_solve_s"], 1e-12))
    return problem, nlp.layout.values(x), row


# --- costs vs no costs (Fig. 4) --------------------------------------------------------------------------
def cost_terms_at(case, model, terrain, values) -> dict[str, float]:
    """The paper's cost terms (½·w·‖r‖² per name, PAPER_PARAMS weights) evaluated at `values`."""
    return evaluate_costs(build_problem(task_of(case), model, terrain, PAPER_PARAMS, heuristic).costs, values)


def peaks(samples) -> dict[str, float]:
    f = np.asarray(samples["forces"])  # (n, legs, 3)
    w = np.asarray(samples["base_ang_vel"])
    return {"peak_force_N": float(np.linalg.norm(f, axis=2).max()),
            "peak_fx_N": float(np.abs(f[..., 0]).max()), "peak_fy_N": float(np.abs(f[..., 1]).max()),
            "peak_fz_N": float(np.abs(f[..., 2]).max()),
            "peak_roll_rate": float(np.abs(w[:, 0]).max()), "peak_pitch_rate": float(np.abs(w[:, 1]).max())}


# --- Table I ----------------------------------------------------------------------------------------------
def fixed_feet(problem):
    for v in problem.variables:
        if v.name == "feet":
            v.fixed = np.ones(v.size, bool)
    return problem


def budget_run(case, model, terrain, params: DynParams, feet_fixed: bool, iterations: int) -> tuple[float, int]:
    """CPU s and LM iterations of one single-stage solve (costs, if any, from the start) from the
    initializer, capped at `iterations`: the per-iteration cost of that problem, the solver's set-up
    (Problem assembly, CHOLMOD analysis) included."""
    problem = build_problem(task_of(case), model, terrain, params, heuristic)
    if feet_fixed:
        fixed_feet(problem)
    t0 = time.process_time()
    result = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints,
                                        replace(params.solver, max_iterations=iterations))
    return time.process_time() - t0, result.iterations


def solve_feet_fixed(case, model, terrain, params: DynParams):
    """No Phase&Feet to convergence: feasibility with the feet fixed, then (with costs) the costs from
    there, as the planner's stages."""
    base = replace(params, costs=CostWeights())
    problem = fixed_feet(build_problem(task_of(case), model, terrain, base, heuristic))
    result = solve_augmented_lagrangian(problem.variables, [], problem.constraints, params.solver)
    iterations, reason = result.iterations, f"feasibility: {result.reason}"
    if result.success and params.costs.active:
        previous = result.values
        problem = fixed_feet(build_problem(task_of(case), model, terrain, params, lambda *_: previous))
        result = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints, params.cost_solver)
        iterations += result.iterations
        reason += f"; costs: {result.reason}"
    return {"success": bool(result.success), "reason": reason, "iterations": iterations,
            "max_violation": float(result.max_violation), "violations": dict(result.violations)}


TABLE_ONE_BUDGET = 30  # LM iterations of the timed runs (the paper's mean is over 100)


def table_one(cases, model, terrains, ours_plain, ours_costs, repeats: int):
    """Per (row, column, costs): first iteration (median of `repeats` one-iteration runs), mean
    iteration (a run capped at TABLE_ONE_BUDGET iterations), and the outcome of the full solve
    (Full: the planner with the phase durations optimized; No Phase: the planner runs above; No
    Phase&Feet: `solve_feet_fixed`)."""
    out = {}
    for column, key in TABLE_ONE_CASES:
        case = cases[key]
        terrain = terrains[case["map"]]
        for with_costs, params in ((False, DynParams()), (True, PAPER_PARAMS)):
            tag = "with costs" if with_costs else "without costs"
            for row_name, feet, phases in (("Full", False, True), ("No Phase", False, False),
                                           ("No Phase&Feet", True, False)):
                run = replace(params, optimize_phases=phases)
                first = statistics.median(budget_run(case, model, terrain, run, feet, 1)[0] for _ in range(repeats))
                cpu, iterations = budget_run(case, model, terrain, run, feet, TABLE_ONE_BUDGET)
                if not feet:
                    done = None if phases else (ours_costs if with_costs else ours_plain).get(key)
                    if done is None:
                        done = run_ours(case, model, terrain, run, 1)[1]
                    full = {k: done[k] for k in ("success", "iterations", "reason", "max_violation")}
                else:
                    full = solve_feet_fixed(case, model, terrain, params)
                out[f"{row_name}|{column}|{tag}"] = {"first_iteration_s": first, "mean_iteration_s": cpu / max(iterations, 1),
                                                     "timed_iterations": iterations, "full_solve": full}
                print(f"  Table I {row_name} {column} {tag}: first {1e3 * first:.0f} ms, mean "
                      f"{1e3 * cpu / max(iterations, 1):.0f} ms over {iterations}; full solve {full['success']} "
                      f"in {full['iterations']} it", flush=True)
    return out


# --- report -----------------------------------------------------------------------------------------------
def fmt(v, digits=3):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "**no**"
    if isinstance(v, float):
        if v != v:
            return "-"
        if v == 0:
            return "0"
        return f"{v:.{digits}g}" if abs(v) >= 1e-3 else f"{v:.1e}"
    return str(v)


def violation_cell(row) -> str:
    """Max violation, and the constraint it is on when above the tolerance."""
    text = fmt(row["max_violation"])
    if row["max_violation"] > VIOLATION_TOL and row.get("violations"):
        text += f" ({max(row['violations'], key=row['violations'].get)})"
    return text


def check_cells(check):
    if check is None:
        return "n/a (check not available)"
    if "error" in check:
        return f"error: {check['error']}"
    w = check["worst"]
    between = check.get("newton_euler_force_rel")
    text = (f"{1e3 * check['penetration_m']:.2f} mm / {check['force_rel']:.1e} / "
            f"{w['newton_euler_force_nodes']:.1e} N" + (f" (10 ms: {100 * between:.1f} % m·g)" if between is not None else "")
            + f" / {w['leg_reach']:.1e} m")
    return text + (" ✓" if check["ok"] else f" ✗ ({', '.join(check['failed'])})")


def targets(result) -> list[str]:
    lines = []
    cases = result["cases"]
    ours = {k: c["ours"] for k, c in cases.items()}
    ok = [k for k, o in ours.items() if o["success"]]
    lines.append(f"every case succeeds: {'met' if len(ok) == len(ours) else 'missed'} ({len(ok)}/{len(ours)}"
                 + ("" if len(ok) == len(ours) else f"; failed: {', '.join(k for k in ours if k not in ok)}") + ")"
                 + (f"; the 2-stride trot TOWR fails: {'solved' if ours.get('flat_trot_2', {}).get('success') else 'not solved'}"
                    if "flat_trot_2" in ours else ""))
    ratios = {k: c["ratio_towr"] for k, c in cases.items() if c.get("ratio_towr") is not None}
    if ratios:
        over = {k: r for k, r in ratios.items() if r > 1.0}
        med = statistics.median(ratios.values())
        lines.append(f"CPU ≤ TOWR's on every case: {'met' if not over else 'missed'}"
                     + ("" if not over else " on " + ", ".join(f"{k} ({r:.2f}×)" for k, r in over.items()))
                     + f"; median ours/TOWR {med:.2f}× (target ≤ 0.5×: {'met' if med <= 0.5 else 'missed'})")
    both = {k: c["ratio_ipopt"] for k, c in cases.items()
            if c.get("ratio_ipopt") is not None and c["ours"]["success"] and c["ipopt"]["success"]}
    ipopt_failed = [k for k, c in cases.items() if c.get("ratio_ipopt") is not None and not c["ipopt"]["success"]]
    if both or ipopt_failed:
        slower = {k: r for k, r in both.items() if r >= 1.0}
        lines.append(f"faster than Ipopt on our formulation: {'met' if not slower else 'missed'} — faster on "
                     f"{len(both) - len(slower)}/{len(both)} cases both solve"
                     + (f" (median ours/Ipopt {statistics.median(both.values()):.2f}×)" if both else "")
                     + ("" if not slower else "; slower on " + ", ".join(f"{k} {r:.2f}×" for k, r in slower.items()))
                     + (f"; Ipopt fails (CPU cap) on {', '.join(ipopt_failed)}" if ipopt_failed else ""))
    bad = {k: o["max_violation"] for k, o in ours.items() if o["max_violation"] > VIOLATION_TOL}
    lines.append(f"max node violation ≤ 1e-3: {'met' if not bad else 'missed'}"
                 + ("" if not bad else " on " + ", ".join(f"{k} ({v:.2g})" for k, v in bad.items())))
    checks = {k: c["ours_check"] for k, c in cases.items() if c.get("ours_check") and "worst" in c["ours_check"]}
    if checks:
        miss = {k: c for k, c in checks.items() if not c["target_met"]}
        lines.append("dense check (no foot > 5 mm below the terrain, force and friction within 1e-3 relative): "
                     + ("met on every case" if not miss else "missed on " + ", ".join(
                         f"{k} ({1e3 * c['penetration_m']:.1f} mm, {c['force_rel']:.1e})" for k, c in miss.items())))
    else:
        lines.append("dense check: not available in this tree (legplan.validate.trajectory missing)")
    cmp_ = result.get("costs", {})
    if cmp_:
        def rate(d):
            return max(d["peak_roll_rate"], d["peak_pitch_rate"])
        good_f = [k for k, c in cmp_.items() if c["with"]["peak_force_N"] < c["without"]["peak_force_N"]]
        good_w = [k for k, c in cmp_.items() if rate(c["with"]) < rate(c["without"])]
        failed = [k for k, c in cmp_.items() if not (c["with"]["success"] and c["without"]["success"])]
        met = len(good_f) == len(good_w) == len(cmp_) and not failed
        lines.append(f"with costs, peak force lower than without: {len(good_f)}/{len(cmp_)} pallet cases, peak "
                     f"roll/pitch rate (larger of the two) lower: {len(good_w)}/{len(cmp_)}"
                     + (f", but the solve with or without costs failed on {', '.join(failed)}" if failed else "")
                     + f" ({'met' if met else 'missed'})")
    return lines


def markdown(result) -> str:
    r = result
    out = [f"## dyn — centroidal trajectory optimization: ours vs Ipopt (same formulation, same run) vs TOWR "
           f"({r['date']}, {r['machine']}, code {r['code']}; load average {r['load_start']:.1f} at start, "
           f"{r['load_end']:.1f} at end; shared machine, other engineers' jobs running; whole bench "
           f"{r['bench_cpu_s'] / 60:.1f} min CPU, {r['bench_wall_s'] / 60:.1f} min wall)", ""]
    out.append(f"CPU seconds (`time.process_time`, one BLAS thread) of the solve, median of {r['repeats']} runs "
               f"(3 where a run takes > {CHEAP:g} s; Ipopt 1 run where it takes > 5 s); set-up (problem build, "
               "sampling) separately. Ours: `plan(task, model, terrain, DynParams())` from the heuristic, "
               "iterations = LM iterations over all stages. Ipopt: " + r["ipopt"]["description"] + " TOWR: the "
               "issue's measurement on this machine (C++, same Ipopt and settings, its own formulation). Dense "
               "check: `legplan.validate.trajectory.check_trajectory` on the 10 ms samples — foot penetration "
               "(max of heightmap and SDF minus half a cell) / worst relative normal-force or friction-pyramid "
               "violation / Newton-Euler force residual at the nodes / leg IK error; ✓ = every metric of the "
               "check passed.")
    out.append("")
    out.append("| case | solver | free vars (paper N) | iterations | CPU solve [s] | setup [s] | success | "
               "max node violation | dense check | ours ÷ this |")
    out.append("|---|---|---|---|---|---|---|---|---|---|")
    for key, c in r["cases"].items():
        o = c["ours"]
        out.append(f"| {c['label']} | ours | {o['variables']} ({o['paper_variables']}) | {o['iterations']} | "
                   f"{o['cpu_solve_s']:.3f} | {o['cpu_setup_s']:.3f} | {fmt(o['success'])} | "
                   f"{violation_cell(o)} | {check_cells(c.get('ours_check'))} | |")
        i = c.get("ipopt")
        if i is not None and "error" not in i:
            swing = "" if i["towr_swing"] else " (without TOWR's swing constraint, as ours)"
            out.append(f"| | Ipopt{swing} | {i['variables']} | {i['iterations']} | {i['cpu_solve_s']:.3f} "
                       f"({100 * i['callback_share']:.0f} % in our callbacks) | "
                       f"{i['cpu_setup_s']:.3f} | {fmt(i['success'])}{'' if i['status'] == 0 else ' (' + i['status_msg'][:40] + ')'} | "
                       f"{violation_cell(i)} | {check_cells(c.get('ipopt_check'))} | "
                       f"{fmt(c.get('ratio_ipopt'))}×{'' if i['success'] else ' (Ipopt failed)'} |")
        elif i is not None:
            out.append(f"| | Ipopt | - | - | - | - | error: {i['error']} | - | - | - |")
        t = c.get("towr")
        if t:
            out.append(f"| | TOWR (issue) | {t['vars']} | {t['iterations']} | {t['cpu']:.2f} | - | "
                       f"{'**no** (violation ' + str(t['violation']) + ')' if t.get('failed') else 'yes'} | - | - | "
                       f"{fmt(c.get('ratio_towr'))}×{' (TOWR failed)' if t.get('failed') else ''} |")
    out.append("")
    diffs = sorted({c["ours"]["paper_variables"] - c["ours"]["variables"] for c in r["cases"].values()})
    out.append(f"Variables: ours free vs the paper's N = 12T/dt + 20S + 120 (in parentheses, equal to TOWR's count "
               f"on its cases): N − ours = {', '.join(map(str, diffs))}, the entries TOWR bounds and we fix "
               "(start node, goal x, y, angles and rates, touchdown/lift-off force nodes).")
    if "stairs_walk" in r["cases"]:
        out.append("Stairs (maps/stairs.yaml, 4 steps of 15 cm rise / 30 cm run, no TOWR figure): 6 walk strides in "
                   "8.0 s from (−0.8, 0, 0) to the landing at (1.7, 0, 0) — the pallet walks' stride timing (TOWR's "
                   "walk stride scaled by the same factor 0.84) and about their stride length (0.42 m vs 0.40 m).")
    out.append("")
    out.append("Targets: " + "; ".join(targets(r)) + ".")
    out.append("")
    if r.get("costs"):
        out.append(f"With the paper's costs ({r['paper_params']}) vs without, pallet cases (Fig. 4): cost terms "
                   "= the paper's blocks evaluated at both answers; peaks over the 10 ms samples (|f| of any foot, "
                   "world roll/pitch rate).")
        out.append("")
        out.append("| case | costs | success | iterations | CPU solve [s] | Σ cost | cost terms | peak ‖f‖ [N] | "
                   "peak fx / fy magnitude [N] | peak roll / pitch rate [rad/s] | dense check |")
        out.append("|---|---|---|---|---|---|---|---|---|---|---|")
        for key, c in r["costs"].items():
            for tag in ("without", "with"):
                d = c[tag]
                terms = ", ".join(f"{k} {v:.3g}" for k, v in d["cost_terms"].items())
                out.append(f"| {r['cases'][key]['label'] if tag == 'without' else ''} | {tag} | {fmt(d['success'])} | "
                           f"{d['iterations']} | {d['cpu_solve_s']:.3f} | {sum(d['cost_terms'].values()):.3g} | "
                           f"{terms} | {d['peak_force_N']:.0f} | {d['peak_fx_N']:.0f} / {d['peak_fy_N']:.0f} | "
                           f"{d['peak_roll_rate']:.3f} / {d['peak_pitch_rate']:.3f} | {check_cells(d.get('check'))} |")
        out.append("")
    if r.get("table_one"):
        out.append("Table I of the paper, CPU per iteration (ms), with costs [without]; ours on this machine, the "
                   "paper's on its onboard computer. Both from the heuristic, one stage (costs from the start): "
                   "1st iter. = a solve capped at one LM iteration (Problem assembly and CHOLMOD analysis "
                   f"included), median of {min(r['repeats'], 3)}; mean = CPU ÷ iterations of a solve capped at "
                   f"{TABLE_ONE_BUDGET} LM iterations (the paper's mean is over 100). Full = the phase durations "
                   "optimized too (`--optimize-phases`); No Phase = our formulation (feet free); No Phase&Feet = "
                   "the ``feet`` variable fixed at the heuristic's footholds (already at the terrain height, the "
                   "paper's adaptation) and swing apexes. Full solve = the outcome when run to convergence "
                   "(Full: the planner with the durations optimized; No Phase: the planner runs above; No "
                   "Phase&Feet: the same stages with the feet fixed).")
        out.append("")
        out.append("| variables optimized | Flat Ground 1st iter. | Flat Ground mean | Pallets 1st iter. | Pallets mean | "
                   "full solve: flat / pallets, with [without] costs | paper Flat 1st / mean | paper Pallets 1st / mean |")
        out.append("|---|---|---|---|---|---|---|---|")
        t1 = r["table_one"]

        def outcome(d):
            f = d["full_solve"]
            return f"{f['iterations']} it" if f["success"] else f"failed ({f['max_violation']:.2g})"
        for row in ("Full", "No Phase", "No Phase&Feet"):
            cells, fulls = [], []
            for column in ("Flat Ground", "Pallets"):
                w, wo = t1.get(f"{row}|{column}|with costs"), t1.get(f"{row}|{column}|without costs")
                if w is None or wo is None:
                    cells += ["not implemented", "not implemented"]
                    continue
                cells.append(f"{1e3 * w['first_iteration_s']:.0f} [{1e3 * wo['first_iteration_s']:.0f}]")
                cells.append(f"{1e3 * w['mean_iteration_s']:.0f} [{1e3 * wo['mean_iteration_s']:.0f}]")
                fulls.append(f"{outcome(w)} [{outcome(wo)}]")
            p = PAPER_TABLE_ONE[row]
            paper = [f"{p[c][0][0]} [{p[c][0][1]}] / {p[c][1][0]} [{p[c][1][1]}]" for c in ("Flat Ground", "Pallets")]
            out.append(f"| {row} | " + " | ".join(cells + [" / ".join(fulls) or "-"] + paper) + " |")
        out.append("")
        def worst(v):
            per = {k: x for k, x in (v["full_solve"].get("violations") or {}).items() if x > VIOLATION_TOL}
            return " (violated: " + ", ".join(f"{k} {x:.2g}" for k, x in per.items()) + ")" if per else ""
        fails = [f"{k.split('|')[0]}, {k.split('|')[1]}, {k.split('|')[2]}: {v['full_solve']['reason']}{worst(v)}"
                 for k, v in t1.items() if not v["full_solve"]["success"] and not k.startswith("No Phase|")]
        if fails:
            out.append("Full and No Phase&Feet full-solve failures: " + "; ".join(fails) + ".")
            out.append("")
    out.append("Ipopt: " + r["ipopt"]["install"])
    return "\n".join(out)


# --- main -------------------------------------------------------------------------------------------------
def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 run each, Ipopt capped at 10 s, dyn_quick.json only")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--ipopt-repeats", type=int, default=3)
    ap.add_argument("--ipopt-max-cpu", type=float, default=40.0, help="Ipopt max_cpu_time (TOWR's: 40 s)")
    ap.add_argument("--ipopt-scaled", action="store_true", help="give Ipopt our solver-side row scales")
    ap.add_argument("--cases", default="", help="comma-separated case keys (default: all)")
    ap.add_argument("--skip-ipopt", action="store_true")
    ap.add_argument("--skip-costs", action="store_true")
    ap.add_argument("--skip-table-one", action="store_true")
    ap.add_argument("--no-append", action="store_true", help="do not write the BENCHMARKS.md section")
    ap.add_argument("--render", action="store_true",
                    help="only rewrite the BENCHMARKS.md section from bench/results/dyn.json (no runs)")
    args = ap.parse_args()
    if args.render:
        result = json.loads((ROOT / "bench" / "results" / "dyn.json").read_text())
        result["targets"] = targets(result)
        write_result("dyn", result)
        update_benchmarks("dyn", markdown(result))
        return
    if args.quick:
        args.repeats, args.ipopt_repeats, args.ipopt_max_cpu = 1, 1, min(args.ipopt_max_cpu, 10.0)
    wanted = [c for c in CASES if not args.cases or c["key"] in args.cases.split(",")]
    wall0, cpu0 = time.perf_counter(), time.process_time()
    load_start = os.getloadavg()[0]
    robot = load_robot("anymal")
    model = robot.centroidal
    maps, terrains = {}, {}
    for case in wanted + [c for c in CASES if c["key"] in dict(TABLE_ONE_CASES).values()]:
        if case["map"] not in maps:
            maps[case["map"]] = build_map(ROOT / "maps" / f"{case['map']}.yaml")
            terrains[case["map"]] = TerrainModel(maps[case["map"]])
    ipopt_ok = cyipopt is not None and not args.skip_ipopt
    ipopt_version = ".".join(map(str, cyipopt.IPOPT_VERSION)) if cyipopt is not None else None
    result = {
        "date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
        "quick": args.quick, "repeats": args.repeats, "load_start": load_start,
        "paper_params": PAPER_SOURCE, "dense_check": check_trajectory is not None,
        "ipopt": {"available": cyipopt is not None, "version": ipopt_version,
                  "cyipopt": getattr(cyipopt, "__version__", None), "options": {**IPOPT_OPTIONS, "max_cpu_time": args.ipopt_max_cpu},
                  "scaled_rows": args.ipopt_scaled,
                  "description": (f"cyipopt {getattr(cyipopt, '__version__', '?')} on Debian's Ipopt {ipopt_version} "
                                  f"(MUMPS, L-BFGS Hessian, tol 1e-3, max_cpu_time {args.ipopt_max_cpu:g} s) on the "
                                  "formulation of `build_problem` (same variables, heuristic start, constraint "
                                  + ("rows times our row scales" if args.ipopt_scaled else "rows in their own units as TOWR's")
                                  + "); success = status 0 and our max violation ≤ 1e-3 at its answer."),
                  "install": ("bench-only, `apt-get install -y coinor-libipopt-dev` (Debian bookworm: Ipopt 3.11.9 "
                              "+ MUMPS 5.5, the build TOWR was measured with) then `.venv/bin/pip install -e '.[bench]'` "
                              "(cyipopt, compiled against it; `make test` does not install it). casadi was not needed.")},
        "cases": {}}
    print(f"machine {result['machine']}, load {load_start:.2f}, code {result['code']}, "
          f"Ipopt {ipopt_version if ipopt_ok else 'not used'}, dense check {'yes' if check_trajectory else 'no'}", flush=True)
    ours_plain, ours_costs, plain_results = {}, {}, {}
    for case in wanted:
        key = case["key"]
        terrain, tmap = terrains[case["map"]], maps[case["map"]]
        res, row = run_ours(case, model, terrain, DynParams(), args.repeats)
        ours_plain[key], plain_results[key] = row, res
        entry = {"label": case["label"], "task": {k: case[k] for k in ("map", "gait", "strides", "duration", "start", "goal")},
                 "ours": row, "towr": case["towr"],
                 "ours_check": dense_check(res.samples, model, tmap, robot, res.problem.form.knots)}
        print(f"{key}: ours {row['cpu_solve_s']:.3f} s, {row['iterations']} it, success {row['success']}, "
              f"viol {row['max_violation']:.1e}, check {check_cells(entry['ours_check'])}", flush=True)
        if case["towr"]:
            entry["ratio_towr"] = row["cpu_solve_s"] / case["towr"]["cpu"]
        if ipopt_ok:
            params = replace(DynParams(), towr_swing=row["towr_swing"])
            try:
                problem, values, irow = run_ipopt(case, model, terrain, params, args.ipopt_repeats,
                                                  args.ipopt_max_cpu, args.ipopt_scaled)
                entry["ipopt"] = irow
                entry["ipopt_check"] = dense_check(planner.sample_solution(problem.form, values), model, tmap, robot,
                                                   problem.form.knots)
                entry["ratio_ipopt"] = row["cpu_solve_s"] / irow["cpu_solve_s"]
                print(f"{key}: Ipopt {irow['cpu_solve_s']:.3f} s, {irow['iterations']} it, status {irow['status']}, "
                      f"viol {irow['max_violation']:.1e}, check {check_cells(entry['ipopt_check'])}", flush=True)
            except Exception as exc:  # noqa: BLE001 - recorded, the bench goes on
                entry["ipopt"] = {"error": f"{type(exc).__name__}: {exc}"}
                print(f"{key}: Ipopt error {exc}", flush=True)
        result["cases"][key] = entry
    if not args.skip_costs:
        result["costs"] = {}
        for case in (c for c in wanted if c["key"] in PALLET_CASES):
            key = case["key"]
            terrain, tmap = terrains[case["map"]], maps[case["map"]]
            res_with, row_with = run_ours(case, model, terrain, PAPER_PARAMS, min(args.repeats, 3))
            ours_costs[key] = row_with
            res_without = plain_results[key]
            c = {}
            for tag, res, row in (("without", res_without, ours_plain[key]), ("with", res_with, row_with)):
                c[tag] = {"success": row["success"], "iterations": row["iterations"], "cpu_solve_s": row["cpu_solve_s"],
                          "max_violation": row["max_violation"], "reason": row["reason"],
                          "cost_terms": cost_terms_at(case, model, terrain, res.solve.values), **peaks(res.samples),
                          "check": dense_check(res.samples, model, tmap, robot, res.problem.form.knots)}
            result["costs"][key] = c
            print(f"{key} costs: {c['with']['cost_terms']} vs {c['without']['cost_terms']}; peaks with "
                  f"{peaks(res_with.samples)} without {peaks(res_without.samples)}", flush=True)
    if not args.skip_table_one:
        cases = {c["key"]: c for c in CASES}
        result["table_one"] = table_one(cases, model, terrains, ours_plain, ours_costs, min(args.repeats, 3))
    result["load_end"] = os.getloadavg()[0]
    result["bench_wall_s"] = time.perf_counter() - wall0
    result["bench_cpu_s"] = time.process_time() - cpu0
    result["targets"] = targets(result)
    text = markdown(result)
    print(text)
    if args.quick:
        write_result("dyn_quick", result)
        return
    write_result("dyn", result)
    if not args.no_append:
        update_benchmarks("dyn", text)


if __name__ == "__main__":
    main()
