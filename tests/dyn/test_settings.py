"""The planner's parameters declared once (`param`) and the one route that sets them: a preset or a
costs file, then `--param` overrides by dotted name, each bad value one line naming the source and field."""

import dataclasses

import pytest

from legplan.dyn.costs import CostWeights
from legplan.dyn.settings import PAPER, DynParams, dyn_params
from legplan.errors import SpecError
from legplan.solve.auglag import ALParams
from legplan.solve.hinged import HingedParams


@pytest.mark.parametrize("cls", [DynParams, CostWeights, ALParams, HingedParams], ids=lambda c: c.__name__)
def test_every_field_is_declared_with_a_doc(cls):
    for f in dataclasses.fields(cls):
        assert "range" in f.metadata and f.metadata["doc"], f"{cls.__name__}.{f.name}"


def test_param_overrides_set_any_field_by_dotted_name():
    params = dyn_params("paper", {"dt": "0.05", "costs.force": "2", "solver.inner.max_iterations": "30",
                                  "swing_height_min": "null", "towr_swing": "true", "warm_stage": "projection"})
    assert params.dt == 0.05 and params.costs.force == 2.0 and params.solver.inner.max_iterations == 30
    assert params.swing_height_min is None and params.towr_swing and params.warm_stage == "projection"
    assert params.costs.force_rate == PAPER.costs.force_rate and params.cost_solver == PAPER.cost_solver
    assert dyn_params("none", {}) == DynParams()


def test_a_costs_file_and_param_overrides_compose(tmp_path):
    costs = tmp_path / "costs.yaml"
    costs.write_text("preset: paper\nforce: 3.0\nleg_clearance: 0.06\n")
    params = dyn_params(str(costs), {"costs.force": "4", "leg_clearance": "null"})
    assert params.costs.force == 4.0 and params.leg_clearance is None
    assert params.costs.swing_height == PAPER.costs.swing_height and params.base_clearance == PAPER.base_clearance


@pytest.mark.parametrize("key, value, message", [
    ("speed", "1", "field 'speed' is unknown"),
    ("costs.speed", "1", "field 'costs.speed' is unknown"),
    ("solver", "1", "field 'solver' is a group of parameters"),
    ("dt.x", "1", "field 'dt' has no fields"),
    ("dt", "fast", "field 'dt' must be a finite number, got 'fast'"),
    ("dt", ".nan", "field 'dt' must be a finite number"),
    ("dt", "0", "field 'dt' must be > 0, got '0'"),
    ("costs.force", "-1", "field 'costs.force' must be >= 0, got '-1'"),
    ("solver.inner.max_iterations", "2.5", "field 'solver.inner.max_iterations' must be a whole number"),
    ("solver.mu_max", "0.5", "field 'solver.mu_max' must be in [mu_init = 1, inf)"),
    ("warm_stage", "feasibility", "field 'warm_stage' must be one of costs, projection, polish"),
    ("towr_swing", "2", "field 'towr_swing' must be true or false"),
    ("dt", "null", "field 'dt' must not be null"),
    ("solver.violation_decrease", "1.5", "field 'solver.violation_decrease' must be in (0, 1]"),
])
def test_bad_param_overrides_are_one_line_naming_the_field(key, value, message):
    with pytest.raises(SpecError) as raised:
        dyn_params("none", {key: value})
    text = str(raised.value)
    assert text.startswith(f"--param: {message}") and "\n" not in text


def test_dyn_plan_takes_param_overrides_and_refuses_a_bad_one_with_one_line(tmp_path):
    """`dyn plan --param`: a bad value is exit 2, one line naming --param and the field, nothing
    written (refused before any planning); a good one is recorded in the artefact's settings."""
    import json
    from pathlib import Path

    import h5py
    from click.testing import CliRunner

    from legplan.cli.main import cli

    root = Path(__file__).resolve().parents[2]
    flat = tmp_path / "flat.h5"
    runner = CliRunner()
    assert runner.invoke(cli, ["map", "build", str(root / "maps" / "flat.yaml"), "-o", str(flat), "-q"]).exit_code == 0
    task = ["dyn", "plan", str(flat), "--gait", "trot", "--strides", "2", "--duration", "1.2",
            "--start", "-0.3", "0", "0", "--goal", "0", "0", "0"]
    out = tmp_path / "bad.h5"
    result = runner.invoke(cli, [*task, "--param", "costs.force=-1", "-o", str(out)])
    assert result.exit_code == 2 and not out.exists() and not (tmp_path / "bad.h5.work").exists()
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--param: field 'costs.force' must be >= 0" in lines[0], result.stderr
    good = tmp_path / "good.h5"
    result = runner.invoke(cli, [*task, "--param", "solver.inner.max_iterations=40", "--param", "dt=0.1",
                                 "-o", str(good), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(good, "r") as f:
        assert json.loads(f.attrs["params"])["dyn"]["solver"]["inner"]["max_iterations"] == 40


def test_the_feasibility_solver_differs_from_the_augmented_lagrangians_defaults_only_by_no_geodesic_acceleration():
    """`DynParams.solver` (the feasibility and range-of-motion stages) is `ALParams()` with the inner
    LM's curvature probe off, and `--param` switches it back on."""
    solver = DynParams().solver
    assert solver.inner.geodesic_acceleration == 0.0 and ALParams().inner.geodesic_acceleration > 0.0
    assert solver == dataclasses.replace(ALParams(), inner=dataclasses.replace(ALParams().inner, geodesic_acceleration=0.0))
    on = dyn_params("none", {"solver.inner.geodesic_acceleration": "0.75"})
    assert on.solver.inner == ALParams().inner
