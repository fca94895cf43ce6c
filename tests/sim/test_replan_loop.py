"""`dyn simulate --replan PERIOD`: the closed loop replans from the simulated state every PERIOD and
records every replan in sim.h5 (issue 39 item 3)."""

import h5py
import numpy as np
from click.testing import CliRunner

from legplan.cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_closed_loop_replans_every_period_and_records_them(flat, tmp_path):
    """A 3 s walk of 2 strides replanned every 0.5 s: 5 replans (none in the last 0.3 s)."""
    traj = tmp_path / "traj.h5"
    planned = invoke("dyn", "plan", flat[1], "--gait", "walk", "--strides", "2", "--duration", "3.0",
                     "--start", "0", "0", "0", "--goal", "0.5", "0.1", "0.1", "-o", traj, "-q")
    assert planned.exit_code == 0, planned.output
    out = tmp_path / "sim.h5"
    result = invoke("dyn", "simulate", traj, flat[1], "--replan", "0.5", "-o", out, "-q")
    with h5py.File(out) as handle:
        task = handle["tasks/0000"]
        replans = {name: task[f"replans/{name}"][()] for name in task["replans"]}
        assert result.exit_code == 0, (result.output, task.attrs["reason"])
        assert task.attrs["success"]
    t = replans["t"]
    assert len(t) == 5 and np.allclose(t, 0.5 * np.arange(1, 6), atol=0.003)
    assert replans["base_pos"].shape == (5, 3) and replans["feet_pos"].shape == (5, 4, 3)
    assert np.all(replans["cpu_seconds"] > 0) and np.all(replans["iterations"] >= 0)
    assert replans["success"].dtype == bool and replans["success"].all()
    assert json_replan(out) == 0.5


def json_replan(path):
    import json
    with h5py.File(path) as handle:
        return json.loads(handle.attrs["params"])["replan"]
