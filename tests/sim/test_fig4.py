"""`legplan dyn show TRAJ TRAJ2 --sim SIM --sim SIM2`: the paper's Fig. 4 with its execution panels
(tracking errors, executed angular rates) from two sim artefacts, and its bad input."""

from __future__ import annotations

import h5py
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def executions(flat, trot, tmp_path_factory):
    """The flat trot executed as planned (reaches the goal) and on ice (falls)."""
    folder = tmp_path_factory.mktemp("fig4")
    ok, fell = folder / "ok.h5", folder / "fell.h5"
    assert invoke("dyn", "simulate", trot, flat[1], "-o", ok, "-q").exit_code == 0
    assert invoke("dyn", "simulate", trot, flat[1], "--friction", "0.1", "-o", fell, "-q").exit_code == 1
    return ok, fell


def _png_height(path) -> int:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[20:24], "big")


def test_fig4_with_executions_adds_two_rows_of_panels(trot, executions, tmp_path):
    plans_only, with_runs = tmp_path / "ad.png", tmp_path / "ah.png"
    assert invoke("dyn", "show", trot, trot, "-o", plans_only, "-q").exit_code == 0
    result = invoke("dyn", "show", trot, trot, "--sim", executions[0], "--sim", executions[1], "-o", with_runs, "-q")
    assert result.exit_code == 0, result.output
    assert _png_height(with_runs) == pytest.approx(2 * _png_height(plans_only), rel=0.02)   # 4 rows of panels, not 2


def test_fig4_reads_the_series_it_draws(executions):
    from legplan.sim.artefact import read_executed

    fell = read_executed(executions[1], 0)
    with h5py.File(executions[1]) as handle:
        assert (fell["series"]["orientation_error"] == handle["tasks/0000/series/orientation_error"][()]).all()
    assert fell["fell"] and fell["series"]["t"][-1] == pytest.approx(fell["fall_time"])


@pytest.mark.parametrize("case", ["one_sim", "sims_without_two_plans", "missing_task"])
def test_fig4_bad_sim_arguments_exit_2_and_write_nothing(trot, executions, tmp_path, case):
    out = tmp_path / "fig.png"
    args = {"one_sim": (trot, trot, "--sim", executions[0]),
            "sims_without_two_plans": (trot, "--sim", executions[0], "--sim", executions[1]),
            "missing_task": (trot, trot, "--task", "0", "--sim", executions[0], "--sim", executions[1])}[case]
    if case == "missing_task":   # a sim artefact without the shown task
        empty = tmp_path / "other.h5"
        with h5py.File(executions[0]) as src, h5py.File(empty, "w") as dst:
            for key, value in src.attrs.items():
                dst.attrs[key] = value
            dst.create_group("tasks")
            src.copy("summary", dst)
        args = (trot, trot, "--sim", executions[0], "--sim", empty)
    result = invoke("dyn", "show", *args, "-o", out)
    assert result.exit_code == 2, result.output
    expected = "other.h5: no task 0" if case == "missing_task" else "--sim: give one sim artefact per traj"
    assert len(result.output.strip().splitlines()) == 1 and expected in result.output, result.output
    assert not out.exists()
