"""`legplan learn dataset`: D = {x_i, y_{h,N}(x_i)} of Sec. IV-A of the TOWR-costs paper, through `legplan.batch`.

    space = read_space("tasks/single_pallet_walk.yaml")
    items = dataset_items(space, n=2000, seed=0)        # (index, DynTask, x)
    task = Task(solve_item, failed_item, DatasetWorker, (space, "heuristic", 100))
    ... run_batch / run_stage ... write_dataset("dataset.h5", space, records, settings)
    records = make_dataset(space, "tasks/single_pallet_walk.yaml", 2000, 0, "heuristic", 100, "d0.h5")  # all of it

Each task is solved by `legplan.dyn.planner.plan` from the initializer A (`heuristic`, A_h, or a
learned init.h5, A_θ) with at most N LM iterations in all (`--iterations`, the planner's
`iteration_budget`: every stage and attempt together; the recorded count is that total). A
solve that does not converge is data, not an error: it is recorded with success false, its cost
and violation. An item that raised is recorded with its reason and y of NaN.

dataset.h5 (kind "dataset"): per task (rows in task order) `x` (n, 6, `space.X_NAMES`), `y` (n, |y|,
`layout`), `cost` g(y) (the space's weighted cost terms at y, as `plan` reports them), `max_violation`,
`iterations`, `seconds` (solve time), `success`, `reason`, `tasks` (n, 6: start x, y, yaw, goal x,
y, yaw); `layout/<category>` sizes; the space as the `space` attribute (JSON). y holds the phase
durations (`legplan.learn.layout`) when the tasks were solved with them optimized (`--optimize-phases`)
or from a network that predicts them (then kept fixed at its values).
"""

from __future__ import annotations

import json
import os
from dataclasses import replace

import numpy as np

from legplan.errors import LegplanError
from legplan.learn.initializers import initializer, is_learned
from legplan.learn.layout import CATEGORIES, join, layout_of, read_layout
from legplan.learn.space import X_NAMES, TaskSpace, load_terrain_map, sample_tasks, task_vector

KIND = "dataset"


def solver_params(costs: str, iterations: int | None, warm_stage: str = "costs", optimize_phases: bool = False):
    """The planner parameters of the space's costs with at most `iterations` LM iterations for the
    whole plan (`DynParams.iteration_budget`: Algorithm 1's N; None: the planner's own caps),
    `DynParams.warm_stage` from a learned guess and `DynParams.optimize_phases`."""
    from legplan.dyn.settings import dyn_params

    return replace(dyn_params(costs), iteration_budget=iterations, warm_stage=warm_stage,
                   optimize_phases=optimize_phases)


def check_init(init: str, space: TaskSpace) -> None:
    """Before any work: `--init` is known, and an init.h5 was trained for this space's map, gait,
    strides, duration and variable layout (one-line error otherwise)."""
    from legplan.dyn.problem import DynTask
    from legplan.learn.network import check_space

    chosen = initializer(init)
    if is_learned(init):
        check_space(init, chosen.space, space.record())
        chosen.check_task(DynTask((0, 0, 0), (0, 0, 0), space.gait, space.strides, space.duration),
                          solver_params(space.costs, None))


class DatasetWorker:
    """What a worker loads once: the centroidal model, the space's terrain, parameters, and the
    initializer `init` names (`legplan.learn.initializers.initializer`)."""

    def __init__(self, space: TaskSpace, init: str, iterations: int | None, warm_stage: str = "costs",
                 optimize_phases: bool = False):
        from legplan.dyn.tasks import centroidal_model
        from legplan.dyn.terrain import TerrainModel
        from legplan.robots import load_robot

        self.params = solver_params(space.costs, iterations, warm_stage, optimize_phases)
        self.model = centroidal_model(load_robot(space.robot), self.params, space.costs)
        self.terrain = TerrainModel(load_terrain_map(space))
        self.initializer = initializer(init)


def dataset_items(space: TaskSpace, n: int, seed: int, worker: DatasetWorker | None = None
                  ) -> list[tuple[int, object, np.ndarray]]:
    """`n` tasks of the space from `numpy.random.default_rng(seed)`: (index, DynTask, x) items, placed
    with the model and terrain of `worker` (None: a worker of the space's heuristic)."""
    if worker is None:
        worker = DatasetWorker(space, "heuristic", None)
    tasks = sample_tasks(space, n, np.random.default_rng(seed), worker.model, worker.terrain)
    return [(i, task, task_vector(task.start, task.goal)) for i, task in enumerate(tasks)]


def run_in_process(task, items, description: str, *, output, identity, inputs, publish):
    """The default batch runner of `make_dataset`: `legplan.batch.run_batch` in this process, no progress
    bar; returns (records, what `publish` returned) as `legplan.cli.batching.run_stage` does."""
    from legplan.batch import run_batch

    with run_batch(task, items, output=output, identity=identity, inputs=inputs) as records:
        return records, publish(records)


def make_dataset(space: TaskSpace, space_path, count: int, seed: int, init, iterations: int | None, output, *,
                 warm_stage: str = "costs", optimize_phases: bool = False, overwrite: bool = False,
                 run=run_in_process) -> list[dict]:
    """Sample `count` tasks of the space (`dataset_items`), solve each from the initializer `init` names
    with at most `iterations` LM iterations, write dataset.h5 to `output`; returns the records.

    `run(task, items, description, *, output, identity, inputs, publish)` runs the batch: in this
    process by default, or the command's `run_stage` with its backend, progress bar and `--resume`."""
    from legplan.batch import Task

    learned = is_learned(init)
    init = os.fspath(init)
    args = (space, os.path.abspath(init) if learned else init, iterations, warm_stage, optimize_phases)
    worker = DatasetWorker(*args)
    items = dataset_items(space, count, seed, worker)
    settings = {"space": space.record(), "n": count, "init": init, "iterations": iterations, "warm_stage": warm_stage,
                "optimize_phases": optimize_phases}
    inputs = [space_path, space.map] + ([init] if learned else [])
    task = Task(solve_item, failed_item, DatasetWorker, args)
    task.provide(worker)  # the robot, terrain and initializer loaded once; the run's workers start with them
    records, _ = run(task, items, f"learn dataset {os.path.basename(output)}", output=output,
                     identity={"stage": "learn dataset", "seed": seed, **settings}, inputs=inputs,
                     publish=lambda records: write_dataset(output, space, records, settings, seed, inputs, overwrite))
    return records


def solve_item(worker: DatasetWorker, item) -> dict:
    """Solve one task (`legplan.batch.Task`'s per-item function) and return its record."""
    from legplan.dyn.planner import plan
    from legplan.dyn.timing import PHASES, foot_durations

    index, task, x = item
    result = plan(task, worker.model, worker.terrain, worker.params, worker.initializer)
    values = dict(result.solve.values)  # the solution (the problem's blocks hold the last stage's start)
    with_phases = worker.params.optimize_phases or predicts_phases(worker.initializer)
    if with_phases:  # the timing the nodes belong to (optimized, or the network's kept fixed)
        values[PHASES] = foot_durations(result.problem.form)
    return {"index": index, "x": x, "task": np.array([*task.start, *task.goal]), "y": join(values),
            "layout": np.array([layout_of(result.problem.form, with_phases)[c] for c in CATEGORIES]),
            "success": bool(result.success), "reason": result.reason, "cost": float(result.solve.cost),
            "max_violation": float(result.solve.max_violation), "iterations": int(result.solve.iterations),
            "seconds": float(result.solve.timings.total)}


def predicts_phases(initializer) -> bool:
    """Whether an initializer's guesses carry phase durations (a network trained with them)."""
    from legplan.dyn.problem import sets_timing

    return sets_timing(initializer)


def failed_item(item, reason: str) -> dict:
    """The record of a task whose solve raised or whose worker died (`legplan.batch.Task`)."""
    index, task, x = item
    return {"index": index, "x": x, "task": np.array([*task.start, *task.goal]), "success": False,
            "reason": reason, "cost": np.nan, "max_violation": np.nan, "iterations": 0, "seconds": np.nan}


def write_dataset(path, space: TaskSpace, records: list[dict], settings: dict, seed: int, inputs, overwrite: bool) -> None:
    """dataset.h5 of the records in item order (module docstring), atomically."""
    import h5py

    from legplan.artefacts import write_artefact, write_dataset as put, write_summary

    solved = [r for r in records if "y" in r]
    if not solved:
        raise LegplanError(f"{path}: no task produced a solution vector (every solve raised: "
                           f"{records[0]['reason'] if records else 'no tasks'})")
    sizes = np.asarray(solved[0]["layout"], int)
    y = np.full((len(records), int(sizes.sum())), np.nan)
    for row, record in enumerate(records):
        if "y" in record:
            y[row] = record["y"]
    column = {name: np.array([r[name] for r in records]) for name in
              ("cost", "max_violation", "iterations", "seconds", "success")}
    with write_artefact(path, KIND, params=settings, seed=seed, inputs=inputs, overwrite=overwrite) as f:
        f.attrs["space"] = json.dumps(space.record())
        put(f, "x", np.array([r["x"] for r in records]), units="m,m,rad,m,m,rad", columns=",".join(X_NAMES))
        put(f, "y", y, units="SI (see layout)")
        put(f, "tasks", np.array([r["task"] for r in records]), units="m,m,rad,m,m,rad")
        for name, size in zip(CATEGORIES, sizes):
            put(f, f"layout/{name}", np.int64(size))
        put(f, "cost", column["cost"], units="1")
        put(f, "max_violation", column["max_violation"], units="1")
        put(f, "iterations", column["iterations"].astype(np.int64))
        put(f, "seconds", column["seconds"], units="s")
        put(f, "success", column["success"].astype(bool))
        f.create_dataset("reason", data=[str(r["reason"]) for r in records], dtype=h5py.string_dtype())
        write_summary(f, summarize(column["success"], column["iterations"], column["cost"], column["seconds"]))


def summarize(success, iterations, cost, seconds) -> dict:
    """Success rate, median iterations and time of the converged tasks, their cost quantiles."""
    ok = np.asarray(success, bool)
    pick = (lambda a, q: float(np.quantile(np.asarray(a, float)[ok], q)) if ok.any() else np.nan)
    return {"tasks": len(ok), "success_rate": float(ok.mean()) if len(ok) else np.nan,
            "median_iterations": pick(iterations, 0.5), "median_seconds": (pick(seconds, 0.5), "s"),
            "cost_median": pick(cost, 0.5), "cost_p90": pick(cost, 0.9), "cost_max": pick(cost, 1.0)}


def read_dataset(path) -> dict:
    """The arrays of a dataset.h5 and its space record (a one-line error for another kind)."""
    from legplan.artefacts import open_artefact, read_array

    with open_artefact(path, kind=KIND) as f:
        data = {"x": read_array(f, "x", ndim=2)}  # task vectors are always finite; outcomes may be NaN
        data.update({name: read_array(f, name, finite=False) for name in
                     ("y", "cost", "max_violation", "iterations", "seconds", "success")})
        data["layout"] = read_layout(f)
        data["space"] = json.loads(f.attrs["space"])
    return data


def best_outcomes(paths) -> dict:
    """Datasets of the same tasks (a cycle's) as one: per task the converged outcome of the lowest cost,
    or the first dataset's when none converged (the arrays of `read_dataset`, `source` per task:
    the index of the dataset it came from). One-line error for a dataset of other tasks or layout."""
    datas = [read_dataset(p) for p in paths]
    first = datas[0]
    for path, data in zip(paths[1:], datas[1:]):
        if data["layout"] != first["layout"]:
            raise LegplanError(f"{path}: field 'layout': not the variable layout of {paths[0]}")
        if data["x"].shape != first["x"].shape or not np.array_equal(data["x"], first["x"]):
            raise LegplanError(f"{path}: field 'x': not the tasks of {paths[0]}")
    cost = np.stack([np.where(np.asarray(d["success"], bool), d["cost"], np.inf) for d in datas])
    source = np.where(np.isfinite(cost).any(axis=0), np.argmin(cost, axis=0), 0)
    rows = np.arange(source.size)
    merged = {name: np.stack([d[name] for d in datas])[source, rows]
              for name in ("y", "cost", "max_violation", "iterations", "seconds", "success")}
    return {**merged, "x": first["x"], "layout": first["layout"], "space": first["space"], "source": source}


def check_space_sizes(space, space_path, warm_stage: str = "costs", optimize_phases: bool = False) -> None:
    """The task space's tasks within the size budget and, with `optimize_phases`, long enough for
    their phases (`legplan.dyn.tasks.check_sizes`), before any task is solved."""
    from legplan.dyn.tasks import check_sizes

    params = solver_params(space.costs, None, warm_stage, optimize_phases)
    check_sizes([space.task((0, 0, 0), (0, 0, 0))], params, space_path, rows=False)
