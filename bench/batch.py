"""Benchmark of `legplan.batch`: the same step-plan items on every backend, side by side in one run.

    .venv/bin/python bench/batch.py [--swings 40] [--repeats 3] [--empty 1000] [--no-append]

Workload: the first --swings whole swings of the gap-crossing sequence (bench/step_plan.py's
scenario and merge_swings: scarab2, maps/gap_crossing.yaml), planned through `run_batch` (work
file included) with --jobs 1 (in-process), --jobs 2 (process pool), a dask LocalCluster of 2
workers and an external `dask scheduler` + 2 `dask worker --nthreads 1` on 127.0.0.1; then the
pre-batch-layer pool (`ProcessPoolExecutor`, 2 workers) with BLAS/OpenMP threads left at their
default, the configuration that made --jobs 2 slower than --jobs 1. Median wall time of --repeats
runs, items/s, speed-up over --jobs 1, CPU seconds of our processes, and the machine's busy cores
during the run (from /proc/stat: ours plus everyone else's, the machine is shared). Per-task
overhead: the marginal wall time of a no-op task on each started backend, from --empty and --empty / 10
tasks (ms per task and worker slot = slope × slots), the intercept, and the work file's cost per item.
Projection: the learned-initializer dataset (2000 tasks × 3 environments × 2 gaits × 4 cycles) on
1, 16 and 128 workers from the measured per-item time and dask overhead. Writes
bench/results/batch.json and its section of BENCHMARKS.md.
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
from common import ROOT, load_average, machine, update_benchmarks, write_result
from step_plan import merge_swings, scenario

DATASET_TASKS = 2000 * 3 * 2 * 4  # TOWR-costs paper Sec. IV-B: tasks × environments × gaits × cycles
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def timed_plan(worker, item) -> dict:
    """`plan_item` plus the item's CPU seconds in its worker (`cpu`), to tell computing from waiting."""
    clock = time.process_time()
    record = worker.plan(*item)
    record["cpu"] = time.process_time() - clock
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
            "item_seconds": sum(float(r.get("seconds", 0.0)) for r in records),
            "item_cpu": sum(float(r.get("cpu", 0.0)) for r in records)}


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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--swings", type=int, default=40, help="whole swings planned per run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--empty", type=int, default=1000, help="no-op tasks of the overhead measurement")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    args = ap.parse_args(argv)

    from legplan.batch import Backend, Task, run_batch
    from legplan.stepplan.batch import StepWorker, failed_item, step_items
    from legplan.stepplan.params import StepPlanParams
    from legplan.stepseq.sequence import read_steps

    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        map_path, steps_path = scenario(tmp, "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
        seq = merge_swings(read_steps(steps_path))
        items = step_items(seq, range(min(args.swings, len(seq) - 1)))
        params = StepPlanParams()
        step_task = Task(timed_plan, failed_item, StepWorker, (seq.robot, str(map_path), params))
        empty_task = Task(nothing, nothing_failed)
        address, cluster = start_dask_cluster(2)
        backends = {"--jobs 1 (in-process)": Backend(1), "--jobs 2 (process pool)": Backend(2),
                    "dask LocalCluster, 2 workers": Backend(2, "local"),
                    "external dask scheduler + 2 workers": Backend(2, address)}
        runs, overhead = {name: [] for name in [*backends, "old pool, 2 workers, default BLAS threads"]}, {}
        try:
            for repeat in range(args.repeats):  # backends interleaved, so load changes hit all of them
                for name, backend in backends.items():
                    def batch(task=step_task, given=items, backend=backend):
                        with run_batch(task, given, output=tmp / "motion.h5", identity={}, backend=backend) as records:
                            return records
                    runs[name].append(measured(batch))
                    print(f"{repeat} {name}: {runs[name][-1]['wall']:.1f} s", file=sys.stderr)
                runs["old pool, 2 workers, default BLAS threads"].append(
                    measured(lambda: old_pool(items, seq.robot, str(map_path), params, 2)))
                print(f"{repeat} old pool: {runs['old pool, 2 workers, default BLAS threads'][-1]['wall']:.1f} s",
                      file=sys.stderr)
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
    result = summarize(runs, overhead, len(items), args, commit, load_start)
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


def summarize(runs, overhead, count, args, commit, load_start) -> dict:
    base = statistics.median(r["wall"] for r in runs["--jobs 1 (in-process)"])
    rows = {}
    for name, measurements in runs.items():
        wall = statistics.median(m["wall"] for m in measurements)
        rows[name] = {"median_wall_s": wall, "walls_s": [m["wall"] for m in measurements], "items_per_s": count / wall,
                      "speedup_vs_jobs1": base / wall,
                      "median_cpu_s": statistics.median(m["cpu"] for m in measurements),
                      "median_item_seconds_sum": statistics.median(m["item_seconds"] for m in measurements),
                      "median_item_cpu_sum": statistics.median(m["item_cpu"] for m in measurements),
                      "median_busy_cores": statistics.median(m["busy_cores"] for m in measurements),
                      "load": [[m["load_before"], m["load_after"]] for m in measurements]}
    per_item = rows["--jobs 1 (in-process)"]["median_item_cpu_sum"] / count  # compute time on a core of its own
    dask_ms = overhead["dask LocalCluster, 2 workers"]["ms_per_task_slot"]
    projection = {workers: DATASET_TASKS * (per_item + dask_ms / 1e3) / workers / 3600 for workers in (1, 16, 128)}
    return {"date": datetime.date.today().isoformat(), "machine": machine(), "commit": commit, "items": count,
            "repeats": args.repeats, "empty_tasks": args.empty, "load_average_start": list(load_start),
            "load_average_end": list(os.getloadavg()), "rows": rows, "overhead": overhead,
            "step_item_seconds": per_item, "dataset_tasks": DATASET_TASKS, "projection_hours": projection}


def markdown(result) -> str:
    rows = result["rows"]
    lines = [f"## batch — one batch layer, every backend on the same items ({result['date']}, {result['commit']})\n",
             f"Machine: {result['machine']}, shared: load average (1/5/15 min) "
             f"{' / '.join(f'{x:.1f}' for x in result['load_average_start'])} at the start, "
             f"{' / '.join(f'{x:.1f}' for x in result['load_average_end'])} at the end. Items: the first "
             f"{result['items']} whole swings of the gap-crossing sequence (scarab2, `StepPlanParams()` defaults), "
             f"through `run_batch` (work file included); median of {result['repeats']} runs, backends interleaved. "
             "'busy cores': the whole machine's during the run (/proc/stat), ours and other users'; "
             "'CPU s': our processes (start-up included). 'Σ item s' / 'Σ item CPU s': wall / CPU time of "
             "the items measured inside the workers (wall ≫ CPU: the item waited for a core).\n",
             "| backend | median wall [s] | items/s | vs --jobs 1 | CPU s | Σ item s | Σ item CPU s | busy cores | runs [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, row in rows.items():
        lines.append(f"| {name} | {row['median_wall_s']:.1f} | {row['items_per_s']:.2f} | {row['speedup_vs_jobs1']:.2f}× "
                     f"| {row['median_cpu_s']:.1f} | {row['median_item_seconds_sum']:.1f} | {row['median_item_cpu_sum']:.1f} | "
                     f"{row['median_busy_cores']:.2f} | {', '.join(f'{w:.1f}' for w in row['walls_s'])} |")
    overhead = "; ".join(f"{name} {o['ms_per_task_slot']:.2f} ms (start {o['start_s']:.2f} s)"
                         for name, o in result["overhead"].items())
    dask_ms = result["overhead"]["dask LocalCluster, 2 workers"]["ms_per_task_slot"]
    per_item, projection = result["step_item_seconds"], result["projection_hours"]
    lines += ["", f"Per-task overhead: marginal wall time of a no-op task on a started backend (executor only), "
              f"from {result['empty_tasks'] // 10} and {result['empty_tasks']} tasks, per worker slot, and the "
              f"intercept (pool: process spawn; dask: already running): {overhead}. A step-plan item computes for {per_item:.2f} s (CPU) here, so dask's "
              f"per-task overhead is {dask_ms / 10 / per_item:.2f} % of it.",
              "", f"Projection on paper (no `dyn plan` task exists yet, so the measured step-plan item CPU time "
              f"{per_item:.2f} s stands in for a task, plus the LocalCluster overhead): the learned-initializer "
              f"dataset of {result['dataset_tasks']} tasks (2000 × 3 environments × 2 gaits × 4 cycles) takes "
              + ", ".join(f"{hours:.1f} h on {workers} worker{'s' if workers > 1 else ''}"
                          for workers, hours in projection.items())
              + " (ideal scaling; the scheduler's own per-task cost is inside the measured overhead)."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
