"""Same inputs and seed give identical artefacts: every producing stage run twice, compared dataset
by dataset and attribute by attribute, except what measures the clock (creation time, wall times)
and the provenance naming the run's own files (command line, input paths and their hashes)."""

import re
from pathlib import Path

import h5py
import numpy as np
from click.testing import CliRunner

from legplan.cli.main import cli

MAPS = Path(__file__).resolve().parents[2] / "maps"
CLOCK = re.compile(r"(^created$|^wall$|time|timings|seconds)")  # names of values read off the clock
RUN = {"command", "inputs"}  # root attributes naming this run's files


def run(*args):
    result = CliRunner().invoke(cli, [str(a) for a in args] + ["-q"])
    assert result.exit_code == 0, result.output + result.stderr
    return result


def contents(path) -> dict:
    """{name: value} of every dataset and attribute of an HDF5 file, clock values left out. A
    summary table (name, value, units rows) keeps its rows whose name is not a clock value."""
    out = {}
    with h5py.File(path, "r") as handle:
        def visit(name, obj):
            for key, value in obj.attrs.items():
                if not (CLOCK.search(key) or (name == "/" and key in RUN)):
                    out[f"{name}@{key}"] = value
            if isinstance(obj, h5py.Dataset) and not CLOCK.search(name):
                value = obj[()]
                if name.endswith("summary"):
                    value = [row for row in value.tolist() if not CLOCK.search(str(row[0]))]
                out[name] = value
        visit("/", handle)
        handle.visititems(visit)
    return out


def assert_same(a, b):
    first, second = contents(a), contents(b)
    assert first.keys() == second.keys()
    for key, value in first.items():
        other = second[key]
        if isinstance(value, np.ndarray):
            assert np.array_equal(value, other, equal_nan=value.dtype.kind == "f"), key
        else:
            assert value == other or (value != value and other != other), key  # NaN (a failed item's) equals NaN


def test_map_steps_and_step_plan_twice(tmp_path, flat_map, box):
    for name in ("a", "b"):
        run("map", "build", MAPS / "flat.yaml", "-o", tmp_path / f"map_{name}.h5")
    assert_same(tmp_path / "map_a.h5", tmp_path / "map_b.h5")

    for name in ("a", "b"):
        run("steps", "generate", flat_map[1], "--robot", "scarab2", "--start", "-0.05", "0", "0",
            "--goal", "0.05", "0", "0", "--seed", "3", "-o", tmp_path / f"steps_{name}.h5")
    assert_same(tmp_path / "steps_a.h5", tmp_path / "steps_b.h5")

    for name in ("a", "b"):
        run("step", "plan", box.map_path, box.steps_file(), "-o", tmp_path / f"motion_{name}.h5")
    assert_same(tmp_path / "motion_a.h5", tmp_path / "motion_b.h5")


def test_nav_search_refine_and_baseline_twice(tmp_path, block_map):
    map_path = block_map
    query = ["--start", 1, 2, "--goal", 7, 2]
    for name in ("a", "b"):
        run("nav", "search", map_path, *query, "-o", tmp_path / f"nav_{name}.h5")
        run("nav", "refine", map_path, tmp_path / f"nav_{name}.h5", "-o", tmp_path / f"teb_{name}.h5")
        run("baseline", "nav", map_path, *query, "--planner", "rrtconnect", "--seed", 4,
            "-o", tmp_path / f"ompl_{name}.h5")
    for kind in ("nav", "teb", "ompl"):
        assert_same(tmp_path / f"{kind}_a.h5", tmp_path / f"{kind}_b.h5")


def test_dyn_plan_twice(tmp_path):
    run("map", "build", MAPS / "flat.yaml", "-o", tmp_path / "flat.h5")
    tasks = tmp_path / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw\n0,0,0,1,0,0\n0,0,0.2,0.8,0.2,0\n")
    for name, jobs in (("a", 1), ("b", 2)):  # in-process, then in a pool of two worker processes
        run("dyn", "plan", tmp_path / "flat.h5", "--tasks", tasks, "--gait", "trot", "--strides", 4,
            "--duration", 2.4, "--jobs", jobs, "-o", tmp_path / f"traj_{name}.h5")
    assert_same(tmp_path / "traj_a.h5", tmp_path / "traj_b.h5")
