"""The batch layer on toy tasks: backends agree, failures are recorded, the work file resumes."""

import h5py
import numpy as np
import pytest

from legplan.batch import Backend, Task, run_batch, work_path
from legplan.batch.workfile import read_record, write_record
from legplan.errors import LegplanError
from toytasks import Context, computed, failed, square, whose

ITEMS = list(range(8))


def task(tmp_path, **context):
    return Task(run=square, failed=failed, setup=Context, args=(str(tmp_path / "calls.log"),
                                                                *context.values()))


def run(tmp_path, backend=Backend(), items=ITEMS, **kwargs):
    output = tmp_path / "out.h5"
    with run_batch(kwargs.pop("task", None) or task(tmp_path), items, output=output,
                   identity={"stage": "toy"}, backend=backend, **kwargs) as records:
        return records


def assert_same_records(a, b):
    assert len(a) == len(b)
    for first, second in zip(a, b):
        assert list(first) == list(second)
        for key, value in first.items():
            if isinstance(value, dict):
                assert value == second[key]
            else:
                assert np.array_equal(value, second[key]), key


def test_in_process_records_in_item_order_failures_recorded_work_file_removed(tmp_path):
    records = run(tmp_path)
    assert [int(r["index"]) for r in records] == ITEMS
    assert not records[3]["success"] and records[3]["reason"] == "ValueError: three is not allowed"
    assert records[5]["value"] == 25.0 and records[5]["nested"] == {"flag": True, "name": "item 5"}
    assert np.array_equal(records[2]["path"], [0.0, 1.0, 2.0])
    assert not work_path(tmp_path / "out.h5").exists()
    assert sorted(computed(tmp_path / "calls.log")) == ITEMS


def test_a_provided_context_serves_in_process_items(tmp_path):
    """`Task.provide`: in-process items use the caller's context; `setup` is not called again."""
    provided = task(tmp_path)
    provided.provide(Context(str(tmp_path / "provided.log")))
    records = run(tmp_path, task=provided)
    assert [int(r["index"]) for r in records] == ITEMS
    assert sorted(computed(tmp_path / "provided.log")) == ITEMS and computed(tmp_path / "calls.log") == []


def test_prestarted_workers_are_taken_over_by_the_pool(tmp_path):
    """`prestart`: the workers started (and importing) before the batch run its items, with the
    in-process records; none are left waiting afterwards."""
    from legplan.batch import backends, prestart

    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    reference = run(tmp_path / "a")
    prestart(2, None, ("toytasks",))
    pool = backends._prestarted[2].pool
    records = run(tmp_path / "b", backend=Backend(jobs=2))
    assert_same_records(reference, records)
    assert 2 not in backends._prestarted and pool._shutdown_thread
    prestart(1, None, ("toytasks",)), prestart(2, "local", ("toytasks",))
    assert not backends._prestarted  # in-process and dask batches start no pool


def run_script(script, *args):
    import os
    import subprocess
    import sys
    from pathlib import Path

    here = Path(__file__).parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(here), str(here.parents[1]), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", script, *map(str, args)], env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


PRESTART_SCRIPT = """
import os, sys
from pathlib import Path
from legplan.batch import Backend, Task, backends, prestart, run_batch
from toytasks import Context, failed, square
gate, out = Path(os.environ["LEGPLAN_TEST_GATE"]), Path(sys.argv[1])
prestart(2, None, ("gatedimport",))
waiting = backends._prestarted[2].thread.is_alive()  # the server is still importing: the gate is shut
gate.write_text("open")
task = Task(run=square, failed=failed, setup=Context, args=(str(out.parent / "calls.log"),))
with run_batch(task, [0, 1, 2], output=out, identity={"stage": "toy"}, backend=Backend(jobs=2)) as records:
    print(waiting, [r["value"] for r in records])
"""


def test_prestart_returns_while_the_fork_server_is_still_importing(tmp_path):
    """`prestart` does not wait for the fork server's imports (the command reads its inputs
    meanwhile); its workers then run the batch. A fresh process, so that its fork server is new."""
    import os

    os.environ["LEGPLAN_TEST_GATE"] = str(tmp_path / "gate")
    try:
        lines = run_script(PRESTART_SCRIPT, tmp_path / "out.h5")
    finally:
        del os.environ["LEGPLAN_TEST_GATE"]
    assert lines == ["True [0.0, 1.0, 4.0]"]


SHARED_SCRIPT = """
import sys
from legplan.batch import Backend, Task, prestart, run_batch
from sharedtasks import Logged, built_by, failed
log, out = sys.argv[1], sys.argv[2]
prestart(2, None, ("sharedtasks",))
task = Task(run=built_by, failed=failed, setup=Logged, args=(log,))
with run_batch(task, list(range(6)), output=out, identity={"stage": "toy"}, backend=Backend(jobs=2)) as records:
    print(" ".join(f"{r['built_by']},{r['pid']},{r['parent']}" for r in records))
if len(sys.argv) > 3:  # a second batch of another task on the same server: its workers build their own
    other = Task(run=built_by, failed=failed, setup=Logged, args=(sys.argv[3],))
    with run_batch(other, [0, 1], output=out, identity={"stage": "toy2"}, backend=Backend(jobs=2)) as records:
        print(" ".join(f"{r['built_by']},{r['pid']},{r['parent']}" for r in records))
"""


def test_prestarted_server_builds_the_task_context_once_for_its_workers(tmp_path):
    """After `prestart`, the fork server builds the batch's task context once and every worker forked
    from it runs with that context (`setup` runs once, in the server); a later task of the same
    command, unknown to the server, gets contexts built by the workers as before."""
    lines = run_script(SHARED_SCRIPT, tmp_path / "setup.log", tmp_path / "out.h5", tmp_path / "other.log")
    rows = [tuple(map(int, entry.split(","))) for entry in lines[0].split()]
    builders = [int(pid) for pid in (tmp_path / "setup.log").read_text().split()]
    servers = {parent for _, _, parent in rows}
    assert len(builders) == 1 and servers == set(builders)  # built once, by the server that forked the workers
    assert {built for built, _, _ in rows} == set(builders) and all(pid != builders[0] for _, pid, _ in rows)
    other = [tuple(map(int, entry.split(","))) for entry in lines[1].split()]
    assert all(built == pid for built, pid, _ in other)  # built in the worker that ran the item
    assert len((tmp_path / "other.log").read_text().split()) == len({pid for _, pid, _ in other})


def test_a_task_file_that_cannot_be_written_leaves_the_workers_to_build_their_contexts(tmp_path):
    """When the command cannot write the task for its fork server, the server goes on without it and
    each worker builds the context itself (the batch neither hangs nor fails)."""
    script = "from pathlib import Path\n" \
             "def refuse(self, data):\n    raise OSError(28, 'No space left on device')\n" \
             "Path.write_bytes = refuse\n" + SHARED_SCRIPT
    lines = run_script(script, tmp_path / "setup.log", tmp_path / "out.h5")
    rows = [tuple(map(int, entry.split(","))) for entry in lines[0].split()]
    assert [built == pid for built, pid, _ in rows] == [True] * 6  # each built in the worker that ran it
    assert len((tmp_path / "setup.log").read_text().split()) == len({pid for _, pid, _ in rows})


def test_a_prestarted_server_that_never_gets_a_task_lets_the_command_end(tmp_path):
    """A command that prestarts workers and then stops before its batch (bad input) ends at once:
    the fork server, still waiting for the task, is told there is none."""
    lines = run_script("from legplan.batch import prestart\nprestart(2, None, ('sharedtasks',))\nprint('ok')")
    assert lines == ["ok"]


FORKED_SCRIPT = """
import os, sys, threading
from legplan.batch import Backend, Task, backends, fork_workers, run_batch
from sharedtasks import Logged, built_by, failed
log, out, threaded = sys.argv[1], sys.argv[2], sys.argv[3] == "threaded"
if threaded:  # a thread already running: no fork from this process
    stop = threading.Event()
    threading.Thread(target=stop.wait, daemon=True).start()
task = Task(run=built_by, failed=failed, setup=Logged, args=(log,))
fork_workers(2, None, task)
print(os.getpid(), 2 in backends._prestarted)
with run_batch(task, list(range(6)), output=out, identity={"stage": "toy"}, backend=Backend(jobs=2)) as records:
    print(" ".join(f"{r['built_by']},{r['pid']},{r['parent']}" for r in records))
print(not backends._prestarted)
"""


def test_forked_workers_run_with_the_context_the_command_built(tmp_path):
    """`fork_workers`: the command builds the task context once and the `--jobs 2` workers are forked
    from it, so `setup` runs once, in the command, and no worker builds it again; with a thread
    already running in the command, the workers come from the fork server and build their own."""
    lines = run_script(FORKED_SCRIPT, tmp_path / "setup.log", tmp_path / "out.h5", "plain")
    command, forked = lines[0].split()
    rows = [tuple(map(int, entry.split(","))) for entry in lines[1].split()]
    assert forked == "True" and lines[2] == "True"  # the pool was taken over, none is left waiting
    assert (tmp_path / "setup.log").read_text().split() == [command]  # built once, in the command
    assert {(built, parent) for built, _, parent in rows} == {(int(command), int(command))}
    assert len({pid for _, pid, _ in rows}) <= 2 and int(command) not in {pid for _, pid, _ in rows}
    lines = run_script(FORKED_SCRIPT, tmp_path / "setup2.log", tmp_path / "out2.h5", "threaded")
    command, forked = lines[0].split()
    rows = [tuple(map(int, entry.split(","))) for entry in lines[1].split()]
    assert forked == "False" and all(built == pid != int(command) for built, pid, _ in rows)
    builders = (tmp_path / "setup2.log").read_text().split()
    assert builders[0] == command and set(builders[1:]) == {str(pid) for _, pid, _ in rows}


def test_fork_workers_with_one_job_builds_the_context_once_and_with_dask_none(tmp_path):
    """`fork_workers` with --jobs 1 builds the context the in-process items then use (setup runs once,
    before the batch); with a dask scheduler it builds nothing (the dask workers build their own)."""
    import os

    from legplan.batch import backends, fork_workers
    from sharedtasks import Logged, built_by
    from sharedtasks import failed as failed_shared

    fork_workers(2, "local", Task(run=built_by, failed=failed_shared, setup=Logged, args=(str(tmp_path / "dask.log"),)))
    assert not (tmp_path / "dask.log").exists() and not backends._prestarted
    one = Task(run=built_by, failed=failed_shared, setup=Logged, args=(str(tmp_path / "one.log"),))
    fork_workers(1, None, one)
    assert (tmp_path / "one.log").read_text().split() == [str(os.getpid())] and not backends._prestarted
    records = run(tmp_path, task=one, items=[0, 1, 2])
    assert [int(r["built_by"]) for r in records] == [os.getpid()] * 3
    assert (tmp_path / "one.log").read_text().split() == [str(os.getpid())]


def test_pool_workers_are_forked_by_one_server_started_by_the_command(tmp_path):
    """`--jobs N` workers are forked by one fork server (libraries imported once), itself a child of the
    command, and the command's environment is left as it was."""
    import os
    from pathlib import Path

    environment = dict(os.environ)
    task = Task(run=whose, failed=failed, setup=Context, args=(str(tmp_path / "calls.log"),))
    records = run(tmp_path, Backend(jobs=2), task=task, items=list(range(6)))
    assert [int(r["index"]) for r in records] == list(range(6))
    servers = {int(r["parent"]) for r in records}
    assert len(servers) == 1 and os.getpid() not in servers and os.getpid() not in {int(r["pid"]) for r in records}
    server_parent = int(Path(f"/proc/{servers.pop()}/stat").read_text().rsplit(")", 1)[1].split()[1])
    assert server_parent == os.getpid()
    assert dict(os.environ) == environment


def test_pool_gives_the_in_process_records_and_survives_a_dying_worker(tmp_path):
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    reference = run(tmp_path / "a")
    crash = Task(run=square, failed=failed, setup=Context, args=(str(tmp_path / "b" / "calls.log"), 6, 0.2))
    records = run(tmp_path / "b", Backend(jobs=2), task=crash)
    assert "worker died" in records[6]["reason"] and not records[6]["success"]
    assert_same_records([r for i, r in enumerate(records) if i != 6],
                        [r for i, r in enumerate(reference) if i != 6])
    calls = computed(tmp_path / "b" / "calls.log")
    assert calls.count(6) == 3  # once with item 5 in flight (0.2 s each), then twice alone


def test_interrupted_batch_resumes_without_recomputing(tmp_path):
    def stop_after_three(done, total, message):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(tmp_path, progress=stop_after_three)
    work = work_path(tmp_path / "out.h5")
    with h5py.File(work, "r") as handle:
        assert len(handle["items"]) == 3
    with pytest.raises(LegplanError, match="--resume continues it"):
        run(tmp_path)
    records = run(tmp_path, Backend(jobs=2), resume=True)
    assert sorted(computed(tmp_path / "calls.log")) == ITEMS  # every item computed exactly once
    (tmp_path / "ref").mkdir()
    assert_same_records(records, run(tmp_path / "ref"))
    assert not work.exists()


@pytest.mark.parametrize("change, message", [
    (dict(identity={"stage": "toy", "samples": 2}), "other parameters"),
    (dict(items=ITEMS[:-1]), "other items"),
    (dict(inputs="other"), "other inputs"),
])
def test_resume_refuses_a_work_file_of_another_batch(tmp_path, change, message):
    source = tmp_path / "input.txt"
    source.write_text("first")
    with pytest.raises(KeyboardInterrupt):
        run(tmp_path, inputs=[source], progress=lambda done, total, m: (_ for _ in ()).throw(KeyboardInterrupt))
    kwargs = dict(identity={"stage": "toy"}, items=ITEMS, inputs=[source])
    if change.get("inputs"):
        source.write_text("second")
    else:
        kwargs.update(change)
    with pytest.raises(LegplanError, match=message):
        with run_batch(task(tmp_path), kwargs.pop("items"), output=tmp_path / "out.h5", resume=True, **kwargs):
            pass
    with run_batch(task(tmp_path), ITEMS, output=tmp_path / "out.h5", identity={"stage": "other"},
                   overwrite=True) as records:
        assert len(records) == len(ITEMS)


def test_record_round_trip_keeps_types_and_key_order(tmp_path):
    record = {"z": 1, "a": np.arange(3.0), "s": "ε reason", "b": True,
              "d": {"y": 2.5, "x": np.zeros((2, 2), np.uint8)}, "e": {}}
    with h5py.File(tmp_path / "r.h5", "w") as handle:
        write_record(handle.create_group("r", track_order=True), record)
        back = read_record(handle["r"])
        with pytest.raises(TypeError, match="'bad'"):
            write_record(handle.create_group("bad"), {"bad": [1, 2]})
    assert list(back) == list(record) and list(back["d"]) == ["y", "x"]
    assert back["z"] == 1 and back["s"] == "ε reason" and back["b"] and back["d"]["y"] == 2.5
    assert back["d"]["x"].dtype == np.uint8 and back["e"] == {}


def test_bad_scheduler_address_and_jobs():
    with pytest.raises(LegplanError, match="--scheduler"):
        Backend(scheduler="somewhere")
    with pytest.raises(LegplanError, match="--jobs"):
        Backend(jobs=0)


def test_dask_local_cluster_gives_the_in_process_records(tmp_path):
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    records = run(tmp_path / "a", Backend(jobs=2, scheduler="local"))
    assert_same_records(records, run(tmp_path / "b"))


def test_dask_records_an_item_that_killed_two_workers_as_failed(tmp_path):
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    crash = Task(run=square, failed=failed, setup=Context, args=(str(tmp_path / "a" / "calls.log"), 2))
    records = run(tmp_path / "a", Backend(jobs=2, scheduler="local"), items=ITEMS[:4], task=crash)
    assert not records[2]["success"] and records[2]["reason"].startswith("worker died (KilledWorker")
    assert computed(tmp_path / "a" / "calls.log").count(2) == 2
    # an innocent item queued on a worker that dies with it counts that death too (dask's
    # allowed-failures rule), so it may also end "worker died"; every other item equals in-process
    reference = run(tmp_path / "b", items=ITEMS[:4])
    kept = [i for i, r in enumerate(records) if i != 2 and not r["reason"].startswith("worker died")]
    assert kept  # at least one innocent item ran on the surviving worker
    assert_same_records([records[i] for i in kept], [reference[i] for i in kept])


def test_dask_reads_each_outcome_by_what_came_back_not_by_the_future_status(monkeypatch):
    """A record whose future no longer reads "finished" (its worker died after it finished, a race a
    CI run met) is still the record; an error tuple or a cancellation is a failed item."""
    import distributed

    from legplan.batch.backends import DaskCluster

    class Future:
        def __init__(self, key):
            self.key, self.status = key, "lost"

        def release(self):
            pass

    class Client:
        def map(self, fn, items, key):
            self.futures = [Future(k) for k in key]
            return self.futures

        def cancel(self, futures):
            pass

    class KilledWorker(Exception):
        pass

    outcomes = [{"index": 0, "success": True}, (KilledWorker, KilledWorker("gone"), None),
                distributed.client.CancelledError("cancelled")]
    monkeypatch.setattr(distributed, "as_completed",
                        lambda futures, **_: iter(zip(futures, outcomes)))
    toy = Task(run=square, failed=failed)
    records = dict(DaskCluster(Client()).run(toy, [(0, 0), (1, 1), (2, 2)]))
    assert records[0] == {"index": 0, "success": True}
    assert records[1] == failed(1, "worker died (KilledWorker: gone)")
    assert not records[2]["success"] and "CancelledError" in records[2]["reason"]


@pytest.mark.parametrize("inherited", ["1", "2"])
def test_blas_threads_limited_unless_one_thread_was_inherited(inherited):
    """A process started with one BLAS/OpenMP thread in its environment has nothing to limit (its
    libraries read it as they loaded); any other setting is limited through threadpoolctl."""
    import os
    import subprocess
    import sys

    code = """
import sys
import numpy
from legplan.batch import Task
from toytasks import square, failed
Task(square, failed).provide(None)
print("threadpoolctl" in sys.modules)
"""
    env = {**os.environ, **dict.fromkeys(("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"), inherited),
           "PYTHONPATH": os.pathsep.join(sys.path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                         cwd=os.path.dirname(__file__))
    assert out.stdout.strip() == ("False" if inherited == "1" else "True")
