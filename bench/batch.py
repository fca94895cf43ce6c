"""Benchmark of `legplan.batch`: the same items on every backend, side by side in one run.

    .venv/bin/python bench/batch.py [--swings 40] [--dyn-tasks 40] [--repeats 3] [--empty 1000] [--no-append]

Workloads: the first --swings whole swings of the gap-crossing sequence (bench/step_plan.py's
scenario and merge_swings: scarab2, maps/gap_crossing.yaml) and --dyn-tasks short `dyn plan`
tasks (anymal trot on maps/flat.yaml), each through `run_batch` (work file included) with --jobs 1
(in-process), --jobs 2 (process pool), a dask LocalCluster of 2 workers and an external `dask
scheduler` + 2 `dask worker --nthreads 1` on 127.0.0.1; for the swings also the pre-batch-layer
pool (`ProcessPoolExecutor`, 2 workers) with BLAS/OpenMP threads left at their default. Median wall
time of --repeats runs, items/s, speed-up over --jobs 1, CPU seconds of our processes, the items'
own wall and CPU time inside the workers, and the machine's busy cores during the run (from
/proc/stat: ours plus everyone else's, the machine is shared). Per-task overhead: the marginal wall
time of a no-op task on each started backend, from --empty and --empty / 10 tasks (ms per task and
worker slot = slope × slots), the intercept, and the work file's cost per item. Projection: the
learned-initializer dataset (2000 tasks × 3 environments × 2 gaits × 4 cycles) on 1, 16 and 128
workers from the measured dyn-plan task CPU time and dask overhead. Writes bench/results/batch.json
and its section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import resource
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import psutil
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result
from step_plan import merge_swings, scenario

DATASET_TASKS = 2000 * 3 * 2 * 4  # TOWR-costs paper Sec. IV-B: tasks × environments × gaits × cycles
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def timed_plan(worker, item) -> dict:
    """`plan_item` plus the item's wall and CPU seconds in its worker (`bench_wall`, `bench_cpu`), to
    tell computing from waiting for a core."""
    wall, cpu = time.perf_counter(), time.process_time()
    record = worker.plan(*item)
    record["bench_wall"], record["bench_cpu"] = time.perf_counter() - wall, time.process_time() - cpu
    return record


def nothing(context, item) -> dict:
    """The empty task of the overhead measurement."""
    return {"success": True}


def nothing_failed(item, reason: str) -> dict:
    return {"success": False, "reason": reason}


def cpu_seconds() -> float:
    """CPU seconds of this process, its finished (waited) descendants and its live descendants."""
    own = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    live = 0.0
    for child in psutil.Process().children(recursive=True):
        try:
            times = child.cpu_times()
            live += times.user + times.system
        except psutil.NoSuchProcess:
            pass
    return sum(u.ru_utime + u.ru_stime for u in own) + live


def machine_ticks() -> tuple[int, int]:
    """(busy, total) jiffies of all cores from /proc/stat."""
    values = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    idle = values[3] + values[4]
    return sum(values) - idle, sum(values)


def measured(run) -> dict:
    """Wall, our CPU seconds, machine busy cores and load around `run()` (which returns records)."""
    cpu0, (busy0, total0), load0, clock = cpu_seconds(), machine_ticks(), load_average(), time.perf_counter()
    records = run()
    wall = time.perf_counter() - clock
    busy1, total1 = machine_ticks()
    cores = os.cpu_count()
    return {"wall": wall, "cpu": cpu_seconds() - cpu0, "busy_cores": (busy1 - busy0) / max(total1 - total0, 1) * cores,
            "load_before": load0, "load_after": load_average(),
            "item_seconds": sum(float(r["bench_wall"]) for r in records),
            "item_cpu": sum(float(r["bench_cpu"]) for r in records)}


def start_dask_cluster(workers: int) -> tuple[str, list[subprocess.Popen]]:
    """A `dask scheduler` and `workers` one-thread `dask worker`s on 127.0.0.1."""
    from distributed import Client

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address, dask = f"tcp://127.0.0.1:{port}", str(Path(sys.executable).parent / "dask")
    common = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0", "--host", "127.0.0.1"]  # loopback only
    processes = [subprocess.Popen([dask, "scheduler", "--port", str(port), *common], stderr=subprocess.DEVNULL)]
    processes += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", *common], stderr=subprocess.DEVNULL)
                  for _ in range(workers)]
    with Client(address, timeout=60) as client:
        client.wait_for_workers(workers, timeout=120)
    return address, processes


_OLD_WORKER = {}


def _old_init(robot, map_path, params):
    from legplan.stepplan.batch import StepWorker

    _OLD_WORKER["worker"] = StepWorker(robot, map_path, params)


def _old_plan(item):
    return timed_plan(_OLD_WORKER["worker"], item)


def old_pool(items, robot, map_path, params, jobs: int) -> list[dict]:
    """The pre-batch-layer pool: every item submitted at once, BLAS/OpenMP threads at their default."""
    saved = {name: os.environ.pop(name) for name in THREAD_VARIABLES if name in os.environ}
    try:
        with ProcessPoolExecutor(jobs, mp_context=get_context("spawn"), initializer=_old_init,
                                 initargs=(robot, map_path, params)) as pool:
            return list(pool.map(_old_plan, items))
    finally:
        os.environ.update(saved)


def dyn_workload(tmp: Path, count: int):
    """`count` short `dyn plan` tasks (anymal trot, 2 strides in 1.2 s, goals 0.30 .. m ahead) on
    maps/flat.yaml: the task and its items."""
    from legplan.batch import Task
    from legplan.dyn.init import heuristic
    from legplan.dyn.items import DynWorker, failed_item, task_items
    from legplan.dyn.settings import dyn_params
    from legplan.dyn.tasks import command_line_task
    from legplan.terrain.spec import build_map
    from legplan.terrain.terrain_map import save_map

    map_path = tmp / "flat.h5"
    save_map(build_map(ROOT / "maps" / "flat.yaml"), map_path)
    tasks = [command_line_task((0.0, 0.0, 0.0), (0.30 + 0.01 * i, 0.0, 0.0), "trot", 2, 1.2) for i in range(count)]
    return Task(timed_plan, failed_item, DynWorker, ("anymal", str(map_path), dyn_params("none"), heuristic)), \
        task_items(tasks)


def step_workload(tmp: Path, count: int):
    """The first `count` whole swings of the gap-crossing sequence: the task, its items and the
    arguments of the old pool."""
    from legplan.batch import Task
    from legplan.stepplan.batch import StepWorker, failed_item, step_items
    from legplan.stepplan.params import StepPlanParams
    from legplan.stepseq.sequence import read_steps

    map_path, steps_path = scenario(tmp, "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
    seq = merge_swings(read_steps(steps_path))
    items = step_items(seq, range(min(count, len(seq) - 1)))
    arguments = (seq.robot, str(map_path), StepPlanParams())
    return Task(timed_plan, failed_item, StepWorker, arguments), items, arguments


OLD = "old pool, 2 workers, default BLAS threads"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--swings", type=int, default=40, help="whole swings planned per run")
    ap.add_argument("--dyn-tasks", type=int, default=40, help="short dyn plan tasks per run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--empty", type=int, default=1000, help="no-op tasks of the overhead measurement")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    args = ap.parse_args(argv)

    from legplan.batch import Backend, Task, run_batch

    commit = code_version()
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        step_task, step_items, old_arguments = step_workload(tmp, args.swings)
        workloads = {"gap-crossing whole swings": (step_task, step_items),
                     "dyn plan tasks": dyn_workload(tmp, args.dyn_tasks)}
        empty_task = Task(nothing, nothing_failed)
        address, cluster = start_dask_cluster(2)
        backends = {"--jobs 1 (in-process)": Backend(1), "--jobs 2 (process pool)": Backend(2),
                    "dask LocalCluster, 2 workers": Backend(2, "local"),
                    "external dask scheduler + 2 workers": Backend(2, address)}
        runs = {(workload, name): [] for workload in workloads for name in [*backends, OLD]
                if workload == "gap-crossing whole swings" or name != OLD}
        overhead = {}
        try:
            for repeat in range(args.repeats):  # backends interleaved, so load changes hit all of them
                for (workload, name), measurements in runs.items():
                    task, items = workloads[workload]
                    if name == OLD:
                        measurements.append(measured(lambda: old_pool(step_items, *old_arguments, 2)))
                    else:
                        def batch(task=task, items=items, backend=backends[name]):
                            with run_batch(task, items, output=tmp / "out.h5", identity={}, backend=backend) as records:
                                return records
                        measurements.append(measured(batch))
                    print(f"{repeat} {workload}, {name}: {measurements[-1]['wall']:.1f} s", file=sys.stderr)
            for name, backend in backends.items():  # marginal cost of a task on a started backend
                executor, walls = backend.start(), {}
                try:
                    for count in (args.empty // 10, args.empty // 10, args.empty):  # the first warms up
                        clock = time.perf_counter()
                        for _ in executor.run(empty_task, [(i, i) for i in range(count)]):
                            pass
                        walls[count] = time.perf_counter() - clock
                finally:
                    executor.close()
                slope = (walls[args.empty] - walls[args.empty // 10]) / (args.empty - args.empty // 10)
                overhead[name] = {"ms_per_task_slot": 1e3 * slope * backend.jobs,
                                  "start_s": walls[args.empty // 10] - slope * (args.empty // 10)}
            overhead["work file (one group, flushed)"] = {"ms_per_task_slot": 1e3 * work_file_seconds(tmp, args.empty),
                                                          "start_s": 0.0}
        finally:
            for process in cluster:
                process.terminate()
            for process in cluster:
                process.wait(timeout=30)
    counts = {workload: len(items) for workload, (_, items) in workloads.items()}
    result = summarize(runs, overhead, counts, args, commit, load_start)
    write_result("batch", result)
    text = markdown(result)
    print(text)
    if not args.no_append:
        update_benchmarks("batch", text)
    return 0


def work_file_seconds(tmp: Path, count: int) -> float:
    """Seconds to store one small record in a work file (create, write, flush)."""
    from legplan.batch.workfile import WorkFile

    work = WorkFile.open(tmp / "work.h5", {}, [], list(range(count)), resume=False, overwrite=True)
    clock = time.perf_counter()
    for position in range(count):
        work.add(position, {"success": True, "seconds": 0.5, "reason": ""})
    seconds = (time.perf_counter() - clock) / count
    work.remove()
    return seconds


def summarize(runs, overhead, counts, args, commit, load_start) -> dict:
    rows = {}
    for (workload, name), measurements in runs.items():
        wall = statistics.median(m["wall"] for m in measurements)
        base = statistics.median(m["wall"] for m in runs[(workload, "--jobs 1 (in-process)")])
        rows[f"{workload} | {name}"] = {
            "median_wall_s": wall, "walls_s": [m["wall"] for m in measurements],
            "items_per_s": counts[workload] / wall, "speedup_vs_jobs1": base / wall,
            "median_cpu_s": statistics.median(m["cpu"] for m in measurements),
            "median_item_seconds_sum": statistics.median(m["item_seconds"] for m in measurements),
            "median_item_cpu_sum": statistics.median(m["item_cpu"] for m in measurements),
            "median_busy_cores": statistics.median(m["busy_cores"] for m in measurements),
            "load": [[m["load_before"], m["load_after"]] for m in measurements]}
    per_task = {workload: rows[f"{workload} | --jobs 1 (in-process)"]["median_item_cpu_sum"] / count
                for workload, count in counts.items()}  # compute time on a core of its own
    dask_ms = overhead["dask LocalCluster, 2 workers"]["ms_per_task_slot"]
    projection = {workers: DATASET_TASKS * (per_task["dyn plan tasks"] + dask_ms / 1e3) / workers / 3600
                  for workers in (1, 16, 128)}
    return {"date": datetime.date.today().isoformat(), "machine": machine(), "commit": commit, "items": counts,
            "repeats": args.repeats, "empty_tasks": args.empty, "load_average_start": list(load_start),
            "load_average_end": list(os.getloadavg()), "rows": rows, "overhead": overhead,
            "task_cpu_seconds": per_task, "dataset_tasks": DATASET_TASKS, "projection_hours": projection}


def markdown(result) -> str:
    counts = result["items"]
    lines = [f"## batch — one batch layer, every backend on the same items ({result['date']}, {result['commit']})\n",
             f"Machine: {result['machine']}, shared: load average (1/5/15 min) "
             f"{' / '.join(f'{x:.1f}' for x in result['load_average_start'])} at the start, "
             f"{' / '.join(f'{x:.1f}' for x in result['load_average_end'])} at the end. Items: the first "
             f"{counts['gap-crossing whole swings']} whole swings of the gap-crossing sequence (scarab2, "
             f"`StepPlanParams()` defaults) and {counts['dyn plan tasks']} short `dyn plan` tasks (anymal, "
             "trot, 2 strides in 1.2 s, maps/flat.yaml), through `run_batch` (work file included); median of "
             f"{result['repeats']} runs, backends interleaved. 'busy cores': the whole machine's during the run "
             "(/proc/stat), ours and other users'; 'CPU s': our processes (start-up included); 'Σ item s' / "
             "'Σ item CPU s': wall / CPU time of the items measured inside the workers (wall ≫ CPU: the item "
             "waited for a core).\n",
             "| workload | backend | median wall [s] | items/s | vs --jobs 1 | CPU s | Σ item s | Σ item CPU s "
             "| busy cores | runs [s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for key, row in result["rows"].items():
        lines.append(f"| {key} | {row['median_wall_s']:.1f} | {row['items_per_s']:.2f} | "
                     f"{row['speedup_vs_jobs1']:.2f}× | {row['median_cpu_s']:.1f} | {row['median_item_seconds_sum']:.1f} "
                     f"| {row['median_item_cpu_sum']:.1f} | {row['median_busy_cores']:.2f} | "
                     f"{', '.join(f'{w:.1f}' for w in row['walls_s'])} |")
    overhead = "; ".join(f"{name} {o['ms_per_task_slot']:.2f} ms (start {o['start_s']:.2f} s)"
                         for name, o in result["overhead"].items())
    dask_ms = result["overhead"]["dask LocalCluster, 2 workers"]["ms_per_task_slot"]
    per_task, projection = result["task_cpu_seconds"], result["projection_hours"]
    lines += ["", f"Per-task overhead: marginal wall time of a no-op task on a started backend (executor only), "
              f"from {result['empty_tasks'] // 10} and {result['empty_tasks']} tasks, per worker slot, and the "
              f"intercept (pool: process spawn; dask: already running): {overhead}. A task computes for "
              + ", ".join(f"{seconds:.2f} s ({workload})" for workload, seconds in per_task.items())
              + f" of CPU here, so dask's per-task overhead is {dask_ms / 10 / per_task['dyn plan tasks']:.2f} % "
              "of a dyn plan task.",
              "", f"Projection on paper from the measured dyn-plan task CPU time ({per_task['dyn plan tasks']:.2f} s, "
              "a short task; the paper's are longer) plus the LocalCluster overhead, ideal scaling: the "
              f"learned-initializer dataset of {result['dataset_tasks']} tasks (2000 × 3 environments × 2 gaits × "
              "4 cycles) takes " + ", ".join(f"{hours:.2f} h on {workers} worker{'s' if workers > 1 else ''}"
                                            for workers, hours in projection.items()) + "."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
