"""Same inputs and seed give identical artefacts: every producing stage run twice, compared dataset
by dataset and attribute by attribute, except what measures the clock (creation time, wall times)
and the provenance naming the run's own files (command line, input paths and their hashes)."""

import re
import sys
from pathlib import Path

import h5py
import numpy as np
from click.testing import CliRunner

from legplan.cli.main import cli
from legplan.stepseq.sequence import StepSequence, write_steps
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap
from legplan.validate.checks import Validator

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "stepplan"))
from scenes import box_scene  # noqa: E402

MAPS = Path(__file__).resolve().parents[2] / "maps"
CLOCK = re.compile(r"(^created$|time|timings|seconds)")  # names of values read off the clock
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


def test_map_steps_and_step_plan_twice(tmp_path):
    for name in ("a", "b"):
        run("map", "build", MAPS / "flat.yaml", "-o", tmp_path / f"map_{name}.h5")
    assert_same(tmp_path / "map_a.h5", tmp_path / "map_b.h5")

    grid = Grid2D(origin=(-0.6, -0.4), resolution=0.01, shape=(81, 121))
    small = tmp_path / "small.h5"
    save_map(terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat_small"), small)
    for name in ("a", "b"):
        run("steps", "generate", small, "--robot", "scarab2", "--start", "-0.05", "0", "0",
            "--goal", "0.05", "0", "0", "--seed", "3", "-o", tmp_path / f"steps_{name}.h5")
    assert_same(tmp_path / "steps_a.h5", tmp_path / "steps_b.h5")

    robot, terrain, map_path, q, stance, footholds = box_scene(tmp_path)
    seq = StepSequence(q=q, stance=stance, footholds=footholds, robot=robot.name, robot_sha256="test",
                       leg_names=[leg.name for leg in robot.legs], joint_names=robot.joint_names)
    steps = tmp_path / "box_steps.h5"
    write_steps(steps, seq, Validator(robot, terrain).check(q, stance, footholds))
    for name in ("a", "b"):
        run("step", "plan", map_path, steps, "-o", tmp_path / f"motion_{name}.h5")
    assert_same(tmp_path / "motion_a.h5", tmp_path / "motion_b.h5")


def test_nav_search_refine_and_baseline_twice(tmp_path):
    height = np.zeros((50, 80))
    height[10:30, 35:45] = 0.5
    map_path = tmp_path / "map.h5"
    save_map(terrain_from_heightmap(height, Grid2D((0.05, 0.05), 0.1, height.shape), name="block"), map_path)
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
