"""`legplan step plan|show` end to end on a small box map with a hand-made jueying_mini sequence."""

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.artefacts import read_summary
from legplan.cli.main import cli
from pictures import pixels, share


@pytest.fixture(scope="module")
def inputs(tmp_path_factory, box):
    """(directory for outputs, the box scene's map and steps.h5 of its three configurations)."""
    return tmp_path_factory.mktemp("stepcli"), box.map_path, box.steps_file()


def test_plan_writes_every_step_and_table2(inputs):
    tmp, map_path, steps_path = inputs
    out = tmp / "motion.h5"
    # default samples (100): with 60, a leg sphere dips 0.25 mm below its clearance between samples of
    # step 1 and the dense re-check rightly records it failed (the sample headroom covers the swing-foot ramp only)
    result = CliRunner().invoke(cli, ["step", "plan", str(map_path), str(steps_path), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out, "r") as f:
        assert f.attrs["legplan_kind"] == "motion"
        assert sorted(f["steps"]) == ["0000", "0001"]
        swing = f["steps/0001"]
        assert swing.attrs["success"] and swing.attrs["degree"] >= 2
        P = swing["control_points"][()]
        assert P.shape == (swing.attrs["degree"] + 1, 18)
        assert swing["lm_iterations"].shape == (swing.attrs["degree"],)
        assert swing["dense/foot_slip"][()] <= 1.0e-3 + 1e-5
        assert json.loads(f.attrs["params"])["samples"] == 100
        summary = read_summary(f)
    assert summary["steps_planned"][0] == 2 and summary["steps_succeeded"][0] == 2
    assert summary["worst_violation"][1] == "m" and 0 <= summary["worst_violation"][0] <= 1.0e-3 + 1e-5
    png = tmp / "motion.png"
    shown = CliRunner().invoke(cli, ["step", "show", str(out), "--map", str(map_path), "-o", str(png)])
    assert shown.exit_code == 0, shown.output + str(shown.exception)
    image = pixels(png)   # histogram bars of the succeeded steps and the first foot's track: tab:blue
    assert share(image, "tab:blue") > 0.005 and share(image, "tab:red") < share(image, "tab:blue")


def test_failed_step_is_recorded_and_exit_1(inputs):
    tmp, map_path, steps_path = inputs
    out = tmp / "failed.h5"
    result = CliRunner().invoke(cli, ["step", "plan", str(map_path), str(steps_path), "-o", str(out),
                                      "--steps", "1:2", "--param", "max_degree=1", "--param", "samples=20"])
    assert result.exit_code == 1
    assert "d_max = 1" in result.stderr
    with h5py.File(out, "r") as f:
        assert list(f["steps"]) == ["0001"]
        step = f["steps/0001"]
        assert not step.attrs["success"] and "ε_num" in step.attrs["reason"]
        assert np.isfinite(step["dense/foot_slip"][()])


@pytest.mark.parametrize("args, message", [
    (["--param", "nope=1"], "step planner parameters: field 'nope' is unknown"),
    (["--param", "samples"], "expected KEY=VALUE, got 'samples'"),
    (["--steps", "5:9"], "has 2 consecutive pairs"),
])
def test_bad_input_exit_2_without_output(inputs, args, message):
    tmp, map_path, steps_path = inputs
    out = tmp / "bad.h5"
    result = CliRunner().invoke(cli, ["step", "plan", str(map_path), str(steps_path), "-o", str(out), *args])
    assert result.exit_code == 2 and message in result.stderr
    assert not out.exists()


def test_plan_reads_the_robot_and_the_map_once(inputs, monkeypatch):
    """`step plan` checks its inputs with the robot and map it reads, and its items are planned on those
    same objects (`Task.provide`): neither file is loaded a second time."""
    import legplan.robots
    import legplan.terrain

    tmp, map_path, steps_path = inputs
    loads = []
    for module, name in ((legplan.robots, "load_robot"), (legplan.terrain, "load_map")):
        original = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, _f=original, _n=name, **k: loads.append(_n) or _f(*a, **k))
    result = CliRunner().invoke(cli, ["step", "plan", str(map_path), str(steps_path), "-o", str(tmp / "once.h5"),
                                      "--steps", "1:2", "--param", "max_degree=1", "--param", "samples=20", "-q"])
    assert result.exit_code == 1, result.output + str(result.exception)  # max_degree 1: the step fails, recorded
    assert sorted(loads) == ["load_map", "load_robot"]
