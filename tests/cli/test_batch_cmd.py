"""Many-item stages through `legplan.batch` end to end (loopback only): every backend gives the
in-process artefact; a killed run resumes without recomputing; a dask worker killed mid-batch
loses nothing; interrupts exit 130 / 143 keeping the work file; bad schedulers and mismatched work
files are refused with one line."""

import os
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from jobs_support import assert_forked_from_command
from test_reproducible import assert_same

from legplan.cli.main import cli

BIN = Path(sys.executable).parent
DONE = re.compile(r"item (\d+) done")
FAST = ["--param", "samples=30", "--param", "dense_samples=200"]


@pytest.fixture(scope="module")
def scene(tmp_path_factory, box):
    """The box scene walked back and forth: 8 pairs (body shifts and swings over the box), and the
    in-process motion.h5 of it."""
    map_path, steps = box.map_path, box.steps_file((0, 1, 2, 1, 0, 1, 2, 1, 0))
    reference = tmp_path_factory.mktemp("batchcli") / "reference.h5"
    result = CliRunner().invoke(cli, ["step", "plan", str(map_path), str(steps), "-o", str(reference), "-q", *FAST])
    assert result.exit_code in (0, 1), result.output
    return map_path, steps, reference, result.exit_code


def plan_argv(scene, output, *extra):
    map_path, steps, _, _ = scene
    return [str(BIN / "legplan"), "step", "plan", str(map_path), str(steps), "-o", str(output), *FAST, *extra]


def start_until_done(argv, count):
    """Start `argv` (with -vv) and return the process once `count` items are reported done."""
    process = subprocess.Popen([*argv, "-vv"], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    done = 0
    for line in process.stderr:
        done += bool(DONE.search(line))
        if done >= count:
            return process
    pytest.fail(f"{argv} ended (exit {process.wait()}) before {count} items were done")


def work_items(path) -> int:
    with h5py.File(path, "r") as handle:
        return len(handle["items"])


@pytest.mark.parametrize("backend", [["--jobs", "2"], ["--scheduler", "local", "--jobs", "2"]])
def test_pool_and_local_cluster_give_the_in_process_artefact(scene, tmp_path, backend):
    output = tmp_path / "motion.h5"
    result = CliRunner().invoke(cli, ["step", "plan", str(scene[0]), str(scene[1]), "-o", str(output), "-q",
                                      *FAST, *backend])
    assert result.exit_code == scene[3], result.output
    assert_same(scene[2], output)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motion.h5"]


def test_workers_forked_by_the_command_give_the_in_process_artefact(scene, tmp_path):
    """`legplan step plan --jobs 2` as its own process: the workers are forked from the command with
    the context it built from the robot and map it read to check its inputs, and it writes the
    in-process motion.h5, clocks aside."""
    output = tmp_path / "motion.h5"
    assert_forked_from_command(["step", "plan", scene[0], scene[1], *FAST], output, scene[2], scene[3])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motion.h5"]


def test_killed_run_resumes_without_recomputing_finished_items(scene, tmp_path):
    output = tmp_path / "motion.h5"
    process = start_until_done(plan_argv(scene, output), 2)
    process.kill()
    process.wait()
    kept = work_items(tmp_path / "motion.h5.work")
    assert kept >= 2 and not output.exists()
    again = subprocess.run([*plan_argv(scene, output, "--resume"), "-vv"], capture_output=True, text=True)
    assert again.returncode == scene[3], again.stderr
    assert f"{kept} of 8 items already done" in again.stderr
    assert len(DONE.findall(again.stderr)) == 8 - kept
    assert_same(scene[2], output)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motion.h5"]


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_keeps_the_work_file_and_says_how_to_resume(scene, tmp_path, signum, code):
    output = tmp_path / "motion.h5"
    process = start_until_done(plan_argv(scene, output, "--jobs", "2"), 1)
    process.send_signal(signum)
    rest = process.stderr.read()
    assert process.wait(timeout=60) == code, rest
    assert "--resume continues" in rest and "Interrupted:" in rest
    assert work_items(tmp_path / "motion.h5.work") >= 1 and not output.exists()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_external_scheduler_loses_nothing_when_a_worker_is_killed(scene, tmp_path):
    import psutil
    from distributed import Client

    address = f"tcp://127.0.0.1:{free_port()}"
    env = {**os.environ, "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1"}
    common = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0", "--host", "127.0.0.1"]  # loopback only
    processes = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--port", address.rsplit(":", 1)[1], *common],
                                  env=env, stderr=subprocess.DEVNULL)]
    try:
        processes += [subprocess.Popen([str(BIN / "dask"), "worker", address, "--nthreads", "1", *common],
                                       env=env, stderr=subprocess.DEVNULL) for _ in range(2)]
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        output = tmp_path / "motion.h5"
        run = start_until_done(plan_argv(scene, output, "--scheduler", address), 1)
        victim, = [child for child in psutil.Process(processes[1].pid).children(recursive=True)
                   if "spawn_main" in " ".join(child.cmdline())]  # the nanny's worker process
        victim.send_signal(signal.SIGKILL)
        rest = run.stderr.read()
        assert run.wait(timeout=300) == scene[3], rest
        assert_same(scene[2], output)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["motion.h5"]
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait(timeout=30)


def test_unreachable_scheduler_is_one_line_exit_2_and_no_output(scene, tmp_path):
    import dask

    output = tmp_path / "motion.h5"
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        result = CliRunner().invoke(cli, ["step", "plan", str(scene[0]), str(scene[1]), "-o", str(output),
                                          "--scheduler", f"tcp://127.0.0.1:{free_port()}"])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--scheduler tcp://127.0.0.1:" in lines[0] and "cannot reach" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_resume_refuses_the_work_file_of_other_inputs(scene, tmp_path):
    from legplan.batch.workfile import WorkFile

    output = tmp_path / "motion.h5"
    WorkFile.open(output, {"stage": "step plan"}, [scene[0]], [1, 2], resume=False, overwrite=False).close()
    result = CliRunner().invoke(cli, ["step", "plan", str(scene[0]), str(scene[1]), "-o", str(output), "--resume"])
    assert result.exit_code == 2
    assert "--resume refused, this work file was started with other parameters" in result.stderr
    without = CliRunner().invoke(cli, ["step", "plan", str(scene[0]), str(scene[1]), "-o", str(output)])
    assert without.exit_code == 2 and "--resume continues it, --overwrite starts over" in without.stderr
    assert not output.exists()


@pytest.mark.parametrize("command", [["nav", "search"], ["baseline", "nav", "--planner", "rrtconnect", "--seed", "4"]])
def test_nav_queries_file_in_a_pool_gives_the_in_process_artefact(tmp_path, command, block_map):
    map_path = block_map
    queries = tmp_path / "queries.csv"
    queries.write_text("start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                       "1,2,0,0,7,2,0,0\n1,1,0,0,4,1.5,0,0\n7,4,0,0,1,0.5,0,0\n")  # the 2nd's goal is in the block
    for name, extra in (("a", []), ("b", ["--jobs", "2"])):
        result = CliRunner().invoke(cli, [*command, str(map_path), "--queries", str(queries), "-q",
                                          "-o", str(tmp_path / f"{name}.h5"), *extra])
        assert result.exit_code == 1 and "0001: failed: goal in collision" in result.stderr, result.output
    assert_same(tmp_path / "a.h5", tmp_path / "b.h5")


def test_dyn_plan_on_a_local_cluster_gives_the_in_process_artefact(tmp_path):
    maps = Path(__file__).resolve().parents[2] / "maps"
    assert CliRunner().invoke(cli, ["map", "build", str(maps / "flat.yaml"), "-o", str(tmp_path / "flat.h5"),
                                    "-q"]).exit_code == 0
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw\n0,0,0,0.4,0,0\n0,0,0.1,0.3,0.1,0\n0,0,0,0.35,0,0\n")
    for name, extra in (("a", []), ("b", ["--scheduler", "local", "--jobs", "2"])):
        result = CliRunner().invoke(cli, ["dyn", "plan", str(tmp_path / "flat.h5"), "--tasks", str(tasks), "--strides",
                                          "2", "--duration", "1.2", "-q", "-o", str(tmp_path / f"{name}.h5"), *extra])
        assert result.exit_code == 0, result.output
    assert_same(tmp_path / "a.h5", tmp_path / "b.h5")
