"""`legplan compare` exit codes, table and JSON."""

import json

from click.testing import CliRunner
from fake_artefacts import write_map, write_motion

from legplan.cli.main import cli


def test_within_tolerance_exit_0_and_table(tmp_path):
    a, b = write_motion(tmp_path / "a.h5"), write_motion(tmp_path / "b.h5", times=(0.6, 1.6, 13.0))
    result = CliRunner().invoke(cli, ["compare", str(a), str(b)])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0].startswith("motion: A = ")
    assert any(line.startswith("clock  mean_time ") and " s " in line for line in lines)
    assert any(line.startswith("ok     worst_violation ") for line in lines)
    assert lines[-1] == "within tolerance"


def test_clock_values_judged_only_with_timings(tmp_path):
    a, b = write_motion(tmp_path / "a.h5"), write_motion(tmp_path / "b.h5", times=(5.0, 15.0, 120.0))
    assert CliRunner().invoke(cli, ["compare", str(a), str(b)]).exit_code == 0
    result = CliRunner().invoke(cli, ["compare", str(a), str(b), "--timings"])
    assert result.exit_code == 1 and result.stdout.splitlines()[-1] == "2 metric(s) out of tolerance"


def test_out_of_tolerance_exit_1_and_tol_option(tmp_path):
    a = write_motion(tmp_path / "a.h5")
    b = write_motion(tmp_path / "b.h5", slips=(1e-7, 2e-7, 5e-3))
    result = CliRunner().invoke(cli, ["compare", str(a), str(b), "--json"])
    assert result.exit_code == 1
    data = json.loads(result.stdout)
    assert data["ok"] is False
    assert {r["name"] for r in data["rows"] if not r["ok"]} == {"worst_violation", "item dense/foot_slip"}
    loose = ["compare", str(a), str(b), "--tol", "worst_violation=0.01", "--tol", "*foot_slip=0.01"]
    assert CliRunner().invoke(cli, loose).exit_code == 0


def test_bad_input_exit_2(tmp_path):
    a, m = write_motion(tmp_path / "a.h5"), write_map(tmp_path / "m.h5")
    result = CliRunner().invoke(cli, ["compare", str(a), str(m)])
    assert result.exit_code == 2 and "cannot compare" in result.stderr
    result = CliRunner().invoke(cli, ["compare", str(a), str(a), "--tol", "x"])
    assert result.exit_code == 2 and "--tol: expected NAME=NUMBER" in result.stderr
