"""`legplan export` / `legplan.export`: motion (Bézier curves timed per step), traj (joints by IK)
and sim (recorded series) as time series in CSV and HDF5; bad input exit 2, nothing written."""

import csv

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from fake_artefacts import write_map, write_robot_motion

from legplan.cli.main import cli
from legplan.export import export_series, foot_radii
from legplan.geometry.bezier import evaluate
from legplan.robots import load_robot
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    """A flat map, a 2.4 s trot of ANYmal planned on it (traj.h5) and executed in MuJoCo (sim.h5)."""
    tmp = tmp_path_factory.mktemp("export")
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    save_map(terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat"), tmp / "map.h5")
    assert invoke("dyn", "plan", tmp / "map.h5", "--start", "0", "0", "--goal", "0.5", "0",
                  "-o", tmp / "traj.h5", "-q").exit_code == 0
    assert invoke("dyn", "simulate", tmp / "traj.h5", tmp / "map.h5", "-o", tmp / "sim.h5", "-q").exit_code in (0, 1)
    return tmp


def test_motion_steps_follow_each_other_timed_uniformly_in_s(tmp_path):
    motion = write_robot_motion(tmp_path / "motion.h5", write_map(tmp_path / "map.h5"), steps=3)
    out = tmp_path / "motion.csv"
    result = invoke("export", motion, "-o", out, "--rate", "10", "--step-duration", "0.5")
    assert result.exit_code == 0, result.output
    with out.open() as handle:
        rows = list(csv.DictReader(handle))
    robot = load_robot("scarab2")
    assert len(rows) == 16 and [float(r["t"]) for r in rows[:3]] == [0.0, 0.1, 0.2]
    with h5py.File(motion) as f:
        points = f["steps/0001/control_points"][()]
    row = rows[7]  # t = 0.7 s: step 1 at s = 0.4
    x = evaluate(points, np.array([0.4]))
    q = robot.from_vector(x)[0]
    assert float(row["base_x"]) == pytest.approx(x[0, 0])
    assert [float(row[name]) for name in robot.joint_names] == pytest.approx(q[7:].tolist())
    feet = robot.foot_positions(q[None])[0]
    leg = robot.legs[2].name
    assert [float(row[f"{leg}_{a}"]) for a in "xyz"] == pytest.approx(feet[2].tolist(), abs=1e-8)
    assert row[f"{leg}_contact"] == "1" and rows[-1]["item"] == "steps"


def test_traj_joints_by_ik_put_the_feet_on_the_plan(executed):
    from legplan.dyn.artefact import read_tasks

    series, = export_series(executed / "traj.h5", 50.0)
    _, tasks = read_tasks(executed / "traj.h5")
    samples = tasks[0]["samples"]
    c = series.columns
    assert c["t"][0] == 0.0 and np.allclose(np.diff(c["t"]), 0.02)
    assert c["t"][-1] == pytest.approx(samples["t"][-1] - samples["t"][0])
    robot = load_robot("anymal")
    planned = samples["feet_pos"][::2] + foot_radii(robot)[None, :, None] * np.array([0, 0, 1.0])
    n = min(len(planned), len(c["t"]))
    assert np.abs(c["feet_pos"][:n] - planned[:n]).max() < 1e-4  # forward kinematics of the IK joints
    assert c["ik_error"].max() < 1e-4
    assert np.array_equal(c["contact"][:n].astype(bool), samples["contact"][::2][:n].astype(bool))
    assert np.allclose(np.linalg.norm(c["base_quat"], axis=1), 1.0)


def test_sim_series_exported_as_an_hdf5_series_artefact(executed):
    out = executed / "sim_series.h5"
    result = invoke("export", executed / "sim.h5", "-o", out, "--rate", "20")
    assert result.exit_code == 0, result.output
    with h5py.File(executed / "sim.h5") as f:
        recorded = {k: f[f"tasks/0000/series/{k}"][()] for k in ("t", "base_pos", "joint_pos")}
    with h5py.File(out) as f:
        assert f.attrs["legplan_kind"] == "series"
        group = f["series/tasks/0000"]
        t, base, joints = group["t"][()], group["base_pos"][()], group["joint_pos"][()]
        assert group["feet_pos"].shape == (len(t), 4, 3) and group["base_pos"].attrs["units"] == "m"
    t_rec = recorded["t"] - recorded["t"][0]
    assert np.allclose(np.diff(t)[:-1], 0.05) and t[-1] == pytest.approx(t_rec[-1])  # the end included
    for k in (0, len(t) // 2, len(t) - 1):
        assert base[k] == pytest.approx([np.interp(t[k], t_rec, recorded["base_pos"][:, i]) for i in range(3)])
    assert joints.shape[1] == 12


def test_bad_input_exits_2_and_writes_nothing(tmp_path, executed):
    bad_suffix = invoke("export", executed / "traj.h5", "-o", tmp_path / "traj.txt")
    assert bad_suffix.exit_code == 2 and "unknown export format" in bad_suffix.stderr
    a_map = invoke("export", write_map(tmp_path / "map.h5"), "-o", tmp_path / "map.csv")
    assert a_map.exit_code == 2 and "map.h5" in a_map.stderr
    assert invoke("export", executed / "traj.h5", "-o", tmp_path / "x.csv", "--rate", "0").exit_code == 2
    assert not any(tmp_path.glob("*.csv")) and not (tmp_path / "traj.txt").exists()
