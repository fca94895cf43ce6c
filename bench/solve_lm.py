"""Benchmark legplan.solve LM against scipy.optimize.least_squares (not a test).

Problems: the step-planner-shaped synthetic problem (N=100 samples, degree 10, 24 columns per
control point, 18 slacks per sample; eq. (12) shape, known root) and Broyden tridiagonal with
n = 10,000 and 100,000. Every solver starts at the same point and stops at the same tolerance
‖h‖ < TOL (scipy through its callback). Each configuration is rebuilt and run REPEATS times in this
process; the median wall time is reported with its ratio to the named reference. legplan runs in
its default configuration (structured "blocks" assembly, JᵀJ formed in Python) and, for Broyden,
with assembly="jacobian" (CHOLMOD factorises JᵀJ + λI from J). A per-iteration profile (cProfile,
one extra run) shows where legplan's time goes on Broyden n = 100,000.

    .venv/bin/python bench/solve_lm.py [--repeats 5] [--skip-exact] [--no-append]

Every solver runs with one BLAS thread (OPENBLAS/OMP/MKL_NUM_THREADS=1 unless set): on the shared
2-core machine multithreaded BLAS oversubscribes the cores and slows scipy's LSMR far more than
CHOLMOD, which made earlier ratios look better than they are. Writes bench/results/solve_lm.json
(with the load average before and after) and replaces the solve_lm section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import cProfile
import datetime
import os
import pstats
import statistics
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy/scipy load BLAS

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from common import ROOT, machine, update_benchmarks, write_result  # noqa: E402
from legplan.solve import CholmodSolver, LMParams, solve_lm  # noqa: E402

sys.path.append(str(ROOT / "tests"))  # the test problems are test support, beside tests/conftest.py
import testproblems as tp  # noqa: E402

TOL = 1e-8


def legplan_run(make, params):
    problem = make()
    t0 = time.perf_counter()
    result = solve_lm(problem, params)
    wall = time.perf_counter() - t0
    t = result.timings
    return wall, result.norm, {"iterations": result.iterations, "status": result.status.value,
                               "evaluate_s": t.evaluate, "assemble_s": t.assemble,
                               "factorize_s": t.factorize, "solve_s": t.solve}


def scipy_run(make, tr_solver):
    problem = make()
    theta0 = problem.layout.initial()
    if tr_solver == "exact":
        jac = lambda th: problem.jacobian(th)[1].toarray()  # noqa: E731 - exact needs a dense Jacobian
    else:
        jac = lambda th: problem.jacobian(th)[1]  # noqa: E731

    def stop(intermediate_result):
        if np.sqrt(2 * intermediate_result.cost) < TOL:
            raise StopIteration

    t0 = time.perf_counter()
    res = least_squares(problem.residual, theta0, jac=jac, method="trf", tr_solver=tr_solver,
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, callback=stop, max_nfev=500)
    wall = time.perf_counter() - t0
    return wall, float(np.linalg.norm(res.fun)), {"nfev": int(res.nfev), "njev": int(res.njev), "status": int(res.status)}


def measure(name, fn, repeats):
    walls, norm, info = [], None, None
    for _ in range(repeats):
        wall, norm, info = fn()
        walls.append(wall)
    row = {"config": name, "median_s": statistics.median(walls), "runs": walls, "final_norm": norm, **info}
    print(f"  {name:34s} median {row['median_s']:8.3f} s  ‖h‖={norm:.2e}  {info}", flush=True)
    return row


def cholmod_mode_comparison(make):
    """Factorisation time of the step-planner JᵀJ (no Schur) per CHOLMOD mode, and forming JᵀJ."""
    problem = make()
    theta = problem.layout.initial()
    _, J = problem.jacobian(theta)
    t0 = time.perf_counter()
    H = (J.T @ J).tocsc()
    form = time.perf_counter() - t0
    out = {"J_shape": list(J.shape), "J_nnz": int(J.nnz), "H_nnz": int(H.nnz), "scipy_JtJ_s": form}
    for mode in ("simplicial", "supernodal"):
        solver = CholmodSolver(mode=mode)
        solver.factorize(H, 1.0)
        times = []
        for lam in (0.5, 0.25, 0.125, 0.0625, 0.03125):
            t0 = time.perf_counter()
            solver.factorize(H, lam)
            times.append(time.perf_counter() - t0)
        out[f"cholmod_{mode}_refactor_s"] = statistics.median(times)
    blocks = problem.normal_equations(theta, "blocks")
    out["structured_normal_equations_s"] = blocks.evaluate_seconds + blocks.assemble_seconds
    return out


# cProfile groups of one legplan solve (cumulative seconds of these functions; Python-level only:
# CHOLMOD's own calls are inside the CholmodSolver methods)
PROFILE_GROUPS = {
    "residual + Jacobian evaluation (blocks)": [("problem.py", "_weighted_linearization")],
    "J stacking / COO → CSC assembly": [("problem.py", "_coo"), ("assembly.py", "assemble_parts")],
    "JᵀJ formation (Python side)": [("problem.py", "_structural_product")],
    "CHOLMOD analysis + ordering choice (once per pattern) and matrix hand-over": [("linsolve.py", "_set")],
    "CHOLMOD numeric factorisation (refactor with beta = λ)": [("linsolve.py", "refactor")],
    "CHOLMOD triangular solves": [("linsolve.py", "solve")],
    "trial-point evaluation (early-reject ‖h‖)": [("problem.py", "trial_norm")],
}


def iteration_profile(make, params):
    """Seconds per PROFILE_GROUPS group for one solve, the rest (LM's λ bookkeeping, steps, norms,
    dict/array handling) as 'LM loop and other Python', and the iteration count."""
    problem = make()
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.enable()
    result = solve_lm(problem, params)
    profiler.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(profiler).stats
    groups = {}
    for group, functions in PROFILE_GROUPS.items():
        groups[group] = sum(v[3] for (path, _, name), v in stats.items()
                            if any(path.endswith(f) and name == fn for f, fn in functions))
    total = next(v[3] for (path, _, name), v in stats.items() if path.endswith("lm.py") and name == "solve_lm")
    groups["LM loop and other Python"] = total - sum(groups.values())
    return {"iterations": result.iterations, "accepted": result.accepted_steps, "profiled_total_s": total,
            "wall_s": wall, "groups_s": groups, "steady_state_s": steady_state(problem, result.theta, params)}


def steady_state(problem, theta, params, repeats=5):
    """Median seconds of each per-iteration piece, repeated at θ on the warm `problem` (patterns
    cached, CHOLMOD analysed once beforehand): what one more LM iteration costs, without the
    one-time work (pattern analysis, symbolic factorisation) that the solve's total includes."""
    def median_time(fn):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)

    values = problem.layout.values(theta)
    ne = problem.normal_equations(theta, params.assembly)
    solver = CholmodSolver()
    hand_over = ((lambda: solver.set_jacobian(ne.jacobian)) if ne.hessian is None
                 else (lambda: solver.set_matrix(ne.hessian)))
    t0 = time.perf_counter()
    hand_over()  # the first hand-over analyses (once per pattern)
    analysis = time.perf_counter() - t0
    solver.refactor(1e-3)
    evaluation = median_time(lambda: [b.evaluate([values[v] for v in b.variables], True) for b in problem.blocks])
    return {"residual + Jacobian evaluation": evaluation,
            "linearisation (evaluation, JᵀJ or J stacking, Jᵀh)": median_time(
                lambda: problem.normal_equations(theta, params.assembly)),
            "CHOLMOD hand-over (pattern check)": median_time(hand_over),
            "CHOLMOD numeric factorisation": median_time(lambda: solver.refactor(1e-3)),
            "CHOLMOD solve": median_time(lambda: solver.solve(ne.gradient)),
            "trial point (full ‖h‖)": median_time(lambda: problem.trial_norm(theta, np.inf)),
            "one-time: CHOLMOD ordering choice + symbolic analysis": analysis}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--skip-exact", action="store_true", help="skip scipy trf/exact (dense SVD, minutes)")
    parser.add_argument("--no-append", action="store_true", help="do not write the BENCHMARKS.md section")
    args = parser.parse_args()
    load_before = os.getloadavg()
    step = lambda: tp.step_planner_like(epsilon=STEP_EPSILON)  # noqa: E731
    base = LMParams(tolerance=TOL)
    jacobian = LMParams(tolerance=TOL, assembly="jacobian")
    cases = {
        "step_planner_like": (step, [
            ("legplan LM + cholmod (structured, Schur)", lambda: legplan_run(step, base)),
            ("legplan LM + scipy (structured, Schur)", lambda: legplan_run(step, LMParams(tolerance=TOL, linear_solver="scipy"))),
            ("legplan LM + dense (structured, Schur)", lambda: legplan_run(step, LMParams(tolerance=TOL, linear_solver="dense"))),
            ("legplan LM + cholmod (stacked, no Schur)", lambda: legplan_run(step, LMParams(tolerance=TOL, assembly="stacked", schur=False))),
            ("scipy least_squares trf/lsmr", lambda: scipy_run(step, "lsmr")),
            *([] if args.skip_exact else [("scipy least_squares trf/exact", lambda: scipy_run(step, "exact"))]),
        ]),
    }
    for n in (10_000, 100_000):
        make = lambda n=n: tp.broyden_tridiagonal(n)  # noqa: E731
        cases[f"broyden_tridiagonal_{n}"] = (make, [
            ("legplan LM + cholmod", lambda make=make: legplan_run(make, base)),
            ("legplan LM + cholmod (assembly=jacobian)", lambda make=make: legplan_run(make, jacobian)),
            ("legplan LM + scipy", lambda make=make: legplan_run(make, LMParams(tolerance=TOL, linear_solver="scipy"))),
            ("scipy least_squares trf/lsmr", lambda make=make: scipy_run(make, "lsmr")),
        ])
    results = {"tolerance": TOL, "repeats": args.repeats, "machine": machine(),
               "date": datetime.date.today().isoformat(), "problems": {}}
    for pname, (make, configs) in cases.items():
        print(pname, flush=True)
        rows = []
        for name, fn in configs:
            repeats = 1 if name.endswith("trf/exact") else args.repeats  # dense SVD per iteration: minutes per run
            rows.append(measure(name, fn, repeats))
        ours = rows[0]["median_s"]
        for row in rows:
            row["ratio_vs_legplan_cholmod"] = row["median_s"] / ours
        entry = {"rows": rows}
        if pname in ("step_planner_like", "broyden_tridiagonal_100000"):
            entry["factorization"] = cholmod_mode_comparison(make)
            print("  ", entry["factorization"], flush=True)
        if pname == "broyden_tridiagonal_100000":
            entry["profile"] = {label: iteration_profile(make, params) for label, params in
                                (("default (blocks)", base), ("assembly=jacobian", jacobian))}
            print("  ", entry["profile"], flush=True)
        results["problems"][pname] = entry
    results["load_average_1_5_15"] = {"before": load_before, "after": os.getloadavg()}
    write_result("solve_lm", results)
    if not args.no_append:
        update_benchmarks("solve_lm", markdown(results))


STEP_EPSILON = 3e-2  # slack bound ε of the synthetic step problem (the step planner uses 1e-3)

HEADER = ("| date | machine | benchmark | case | config | median (s) | ratio | reference | notes |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n")


def speedups(rows) -> str:
    """'scipy trf/lsmr ÷ legplan' for every legplan CHOLMOD row of one problem."""
    scipy_row = next(r for r in rows if r["config"] == "scipy least_squares trf/lsmr")
    return "; ".join(f"{r['config']}: {scipy_row['median_s'] / r['median_s']:.2f}× "
                     f"(min ÷ min {min(scipy_row['runs']) / min(r['runs']):.2f}×)" for r in rows
                     if r["config"].startswith("legplan LM + cholmod"))


def step_differences(median: dict[str, float]) -> str:
    """Where the two sides of the step_planner_like rows differ, with this run's numbers."""
    ours, scipy_lsmr = median["legplan LM + cholmod (structured, Schur)"], median["scipy least_squares trf/lsmr"]
    stacked, dense = median["legplan LM + cholmod (stacked, no Schur)"], median["legplan LM + dense (structured, Schur)"]
    return (f"Where the sides differ (step_planner_like): the headline {scipy_lsmr / ours:.2f}× is legplan's structured "
            "path (JᵀJ formed from the curve's per-sample blocks, Schur elimination of the slacks) against scipy on the stacked "
            f"sparse Jacobian; with the same stacked assembly legplan is {scipy_lsmr / stacked:.2f}× faster. The problem "
            f"is synthetic with slack bound ε = {STEP_EPSILON:g} (the step planner uses 1e-3), and on it the dense "
            f"linear solver beats CHOLMOD ({dense:.3f} s vs {ours:.3f} s): after the Schur step the reduced "
            "system is small and dense.")


def markdown(results) -> str:
    """The section: one row per configuration (ratio = its median / legplan LM + cholmod's), the
    speed-ups over scipy and the per-iteration profile of Broyden n = 100,000."""
    load = " → ".join(f"{results['load_average_1_5_15'][k][0]:.1f}" for k in ("before", "after"))
    lines = [f"## solve_lm — legplan LM vs scipy least_squares ({results['date']})\n\n",
             f"Every solver from the same start to ‖h‖ < {results['tolerance']:.0e}, one BLAS thread, "
             f"median of {results['repeats']} runs in one process, 1-min load average {load} "
             f"(shared 2-core machine). Written by bench/solve_lm.py.\n\n", HEADER]
    for pname, entry in results["problems"].items():
        for row in entry["rows"]:
            lines.append(f"| {results['date']} | {results['machine']} | solve_lm | {pname} | {row['config']} | "
                         f"{row['median_s']:.3f} | {row['ratio_vs_legplan_cholmod']:.2f}× | legplan LM + cholmod | "
                         f"‖h‖={row['final_norm']:.1e}, median of {len(row['runs'])}, min {min(row['runs']):.3f} s |\n")
    lines.append("\nSpeed-up over scipy least_squares trf/lsmr (median ÷ median): " + " · ".join(
        f"{pname}: {speedups(entry['rows'])}" for pname, entry in results["problems"].items()) + ".\n")
    step = results["problems"].get("step_planner_like")
    if step:
        lines.append("\n" + step_differences({row["config"]: row["median_s"] for row in step["rows"]}) + "\n")
    for pname, entry in results["problems"].items():
        f = entry.get("factorization")
        if f:
            lines.append(f"\n{pname}: JᵀJ {f['H_nnz']} entries; CHOLMOD refactor (beta = λ, median of 5) simplicial "
                         f"{1e3 * f['cholmod_simplicial_refactor_s']:.2f} ms, supernodal "
                         f"{1e3 * f['cholmod_supernodal_refactor_s']:.2f} ms.\n")
    profile = results["problems"].get("broyden_tridiagonal_100000", {}).get("profile", {})
    for label, p in profile.items():
        parts = ", ".join(f"{group} {1e3 * s:.1f}" for group, s in p["groups_s"].items())
        steady = ", ".join(f"{piece} {1e3 * s:.2f}" for piece, s in p["steady_state_s"].items())
        lines.append(f"\nProfile, Broyden n = 100,000, legplan {label}: {p['iterations']} iterations "
                     f"({p['accepted']} accepted, so {p['iterations']} linearisations, factorisations, solves and "
                     f"trial points). Whole solve under cProfile ({1e3 * p['profiled_total_s']:.0f} ms, one-time "
                     f"work included), ms: {parts}. One more iteration at the solution, warm (median of 5), "
                     f"ms: {steady}.\n")
    return "".join(lines)


if __name__ == "__main__":
    main()
