"""Fixtures of the sim tests: the shipped anymal, a flat map with a block, a planned flat trot, and a
traj.h5 of two tasks of which the second did not solve."""

import numpy as np
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli
from legplan.robots import load_robot
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap

TROT = ("--start", "0", "0", "0", "--goal", "1", "0", "0", "--gait", "trot", "--strides", "4", "--duration", "2.4")


def _plan(*args):
    result = CliRunner().invoke(cli, ["dyn", "plan", *[str(a) for a in args], "-q"])
    return result


@pytest.fixture(scope="session")
def robot():
    return load_robot("anymal")


@pytest.fixture(scope="session")
def flat(tmp_path_factory):
    """A flat 3 x 2 m map at 2 cm with a 10 cm block at x >= 1.2 (to check the height field)."""
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    x, y = grid.centres()
    terrain = terrain_from_heightmap(np.where(x >= 1.2, 0.1, 0.0), grid, name="flat_block")
    path = tmp_path_factory.mktemp("sim") / "map.h5"
    save_map(terrain, path)
    return terrain, path


@pytest.fixture(scope="session")
def trot(flat, tmp_path_factory):
    """A 1 m flat trot planned by `legplan dyn plan` (4 strides, 2.4 s)."""
    traj = tmp_path_factory.mktemp("trot") / "traj.h5"
    assert _plan(flat[1], *TROT, "-o", traj).exit_code == 0
    return traj


@pytest.fixture(scope="session")
def two_tasks(flat, tmp_path_factory):
    """traj.h5 of a 0.3 m trot that solves and a 1.5 m trot in 0.4 s (one stride) that does not."""
    folder = tmp_path_factory.mktemp("two")
    tasks = folder / "tasks.csv"
    tasks.write_text("start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw,gait,strides,duration\n"
                     "0,0,0,0.3,0,0,trot,2,1.2\n0,0,0,1.5,0,0,trot,1,0.4\n")
    traj = folder / "traj.h5"
    assert _plan(flat[1], "--tasks", tasks, "-o", traj).exit_code == 1   # one task failed
    return traj
