"""`legplan dyn replan TRAJ STATE --map MAP -o OUT`: the rest of a plan from a measured state; bad
input is one line naming the file and the field, exit 2, nothing written."""

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from legplan.cli.main import cli
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """A flat map, a 2-stride walk planned on it, and the state its samples hold at t = 1.0 s."""
    tmp = tmp_path_factory.mktemp("replan")
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    map_path = tmp / "map.h5"
    save_map(terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat"), map_path)
    traj = tmp / "traj.h5"
    result = invoke("dyn", "plan", map_path, "--gait", "walk", "--strides", "2", "--duration", "3.0",
                    "--start", "0", "0", "0", "--goal", "0.5", "0.1", "0.1", "-o", traj, "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(traj, "r") as f:
        s = {name: f[f"tasks/0000/samples/{name}"][()] for name in
             ("t", "base_pos", "base_euler", "base_vel", "base_ang_vel", "feet_pos")}
    k = int(np.argmin(np.abs(s["t"] - 1.0)))
    state = {"t": float(s["t"][k]), "task": 0, "feet_pos": s["feet_pos"][k].tolist(),
             **{name: s[name][k].tolist() for name in ("base_pos", "base_euler", "base_vel", "base_ang_vel")}}
    state["base_vel"][1] += 0.2  # a lateral push
    return tmp, map_path, traj, state


def _state_file(tmp, state, name="state.yaml"):
    path = tmp / name
    path.write_text(yaml.safe_dump(state))
    return path


def test_replan_writes_the_rest_from_the_state(planned):
    tmp, map_path, traj, state = planned
    out = tmp / "rest.h5"
    result = invoke("dyn", "replan", traj, _state_file(tmp, state), "--map", map_path, "-o", out, "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out, "r") as f:
        task = f["tasks/0000"]
        assert task.attrs["solved"]
        assert task["samples/t"][-1] == pytest.approx(3.0 - state["t"])
        assert np.allclose(task["samples/base_vel"][0], state["base_vel"], atol=1e-9)
        assert np.allclose(task["samples/base_pos"][0], state["base_pos"], atol=1e-9)


BAD = [
    ("t", "late", "'t'"),
    ("t", 3.5, "'t'"),
    ("t", None, "'t'"),
    ("base_vel", [0.0, 1.0], "'base_vel'"),
    ("base_pos", [0.0, "x", 0.4], "'base_pos[1]'"),
    ("base_euler", [0.0, float("nan"), 0.0], "'base_euler[1]'"),
    ("feet_pos", [[0, 0, 0]] * 3, "'feet_pos'"),
    ("task", 4, "'task'"),
    ("task", -1, "'task'"),
    ("velocity", [1, 2, 3], "'velocity'"),
    ("contact", [True, True, False], "'contact'"),
    ("contact", [1, 1, 0, 1], "'contact'"),
    ("contact", "yes", "'contact'"),
]


def test_sensed_contacts_make_a_late_foot_land_from_where_it_is(planned):
    """The state file's `contact`: a foot its plan stands on at t, sensed off the ground 4 cm above
    the terrain, starts the rest in the air where it was measured (`lifted_feet`) with no force;
    without `contact` it stands on the terrain from t."""
    tmp, map_path, traj, state = planned
    with h5py.File(traj, "r") as f:
        standing = f["tasks/0000/samples/contact"][()]
        times = f["tasks/0000/samples/t"][()]
    k = int(np.argmin(np.abs(times - state["t"])))
    leg = int(np.flatnonzero(standing[k])[0])
    lifted = {**state, "feet_pos": [list(p) for p in state["feet_pos"]]}
    lifted["feet_pos"][leg][2] += 0.04
    firsts = {}
    for name, extra in (("sensed", {"contact": [i != leg for i in range(4)]}), ("plain", {})):
        out = tmp / f"rest_{name}.h5"
        result = invoke("dyn", "replan", traj, _state_file(tmp, {**lifted, **extra}, f"{name}.yaml"), "--map",
                        map_path, "-o", out, "-q")
        assert result.exit_code == 0, result.output + str(result.exception)
        with h5py.File(out, "r") as f:
            firsts[name] = (f["tasks/0000/samples/feet_pos"][0, leg], f["tasks/0000/samples/contact"][0, leg],
                            f["tasks/0000/samples/forces"][0, leg])
    feet, contact, force = firsts["sensed"]
    assert np.allclose(feet, lifted["feet_pos"][leg], atol=1e-6) and not contact and np.abs(force).max() < 1e-6
    feet, contact, _ = firsts["plain"]
    assert contact and abs(feet[2]) < 1e-3


@pytest.mark.parametrize("field, value, named", BAD)
def test_bad_state_is_one_line_exit_2_nothing_written(planned, field, value, named):
    tmp, map_path, traj, state = planned
    bad = {**state, field: value}
    if value is None:
        del bad[field]
    path = _state_file(tmp, bad, "bad.yaml")
    out = tmp / "never.h5"
    result = invoke("dyn", "replan", traj, path, "--map", map_path, "-o", out)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "bad.yaml" in lines[0] and named in lines[0], result.output
    assert not out.exists()


@pytest.mark.parametrize("content", ["", "[1, 2]", "t: [", "\x00\x01binary"])
def test_state_file_not_a_mapping(planned, content):
    tmp, map_path, traj, _ = planned
    path = tmp / "garbage.yaml"
    path.write_text(content)
    out = tmp / "never.h5"
    result = invoke("dyn", "replan", traj, path, "--map", map_path, "-o", out)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "garbage.yaml" in lines[0], result.output
    assert not out.exists()


def test_missing_state_file_and_bad_traj(planned):
    tmp, map_path, traj, state = planned
    out = tmp / "never.h5"
    result = invoke("dyn", "replan", traj, tmp / "none.yaml", "--map", map_path, "-o", out)
    assert result.exit_code == 2 and "none.yaml" in result.output and not out.exists()
    garbage = tmp / "garbage.h5"
    garbage.write_bytes(b"not hdf5")
    result = invoke("dyn", "replan", garbage, _state_file(tmp, state), "--map", map_path, "-o", out)
    assert result.exit_code == 2 and "garbage.h5" in result.output and not out.exists()
