"""`legplan steps`: generate on a small flat map, export/import round trip, show, import errors."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli

EXAMPLE = Path(__file__).parents[1] / "data" / "steps_example.csv"


@pytest.fixture(scope="module")
def generated(flat_map, tmp_path_factory):
    out = tmp_path_factory.mktemp("steps") / "steps.h5"
    result = CliRunner().invoke(cli, ["steps", "generate", str(flat_map[1]), "--robot", "scarab2",
                                      "--start", "-0.05", "0", "0", "--goal", "0.05", "0", "0",
                                      "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + result.stderr
    return out


def _content(path):
    with h5py.File(path, "r") as f:
        return {name: f[name][()] for name in ("q", "stance", "footholds")}, dict(f.attrs)


def test_generated_sequence_is_valid_and_switches_one_leg_at_a_time(generated):
    data, attrs = _content(generated)
    assert attrs["robot"] == "scarab2" and attrs["success"]
    stance = data["stance"].astype(bool)
    assert len(stance) >= 4
    assert np.all(np.abs(np.diff(stance.astype(int), axis=0)).sum(axis=1) <= 1)
    with h5py.File(generated, "r") as f:
        summary = {row["name"].decode(): row["value"] for row in f["summary"][()]}
    assert summary["worst_foot_gap"] <= 1e-3
    assert summary["min_com_margin"] > 0 and summary["min_clearance"] > 0
    # judged on every constraint against what the generator promises, each with its tolerance
    for name in ("foot_slip", "com_margin", "clearance", "joint_limits"):
        assert summary[f"worst_shortfall_{name}"] <= 0 and f"tolerance_{name}" in summary
    with h5py.File(generated, "r") as f:
        assert f["checks/shortfall_clearance"].shape == (len(stance),)
        assert json.loads(f.attrs["requirements"])["clearance"] == 0.02


@pytest.mark.parametrize("suffix", ["csv", "json", "yaml"])
def test_export_import_round_trip(generated, flat_map, tmp_path, suffix):
    runner = CliRunner()
    exported = tmp_path / f"steps.{suffix}"
    assert runner.invoke(cli, ["steps", "export", str(generated), "-o", str(exported)]).exit_code == 0
    again = tmp_path / "again.h5"
    result = runner.invoke(cli, ["steps", "import", str(exported), "--robot", "scarab2", "--map",
                                 str(flat_map[1]), "-o", str(again), "--strict"])
    assert result.exit_code == 0, result.stderr
    before, attrs_before = _content(generated)
    after, attrs_after = _content(again)
    np.testing.assert_array_equal(before["q"], after["q"])
    np.testing.assert_array_equal(before["stance"], after["stance"])
    np.testing.assert_array_equal(before["footholds"], after["footholds"])
    for key in ("robot", "robot_sha256", "leg_names", "joint_names"):
        assert attrs_before[key] == attrs_after[key]


def test_example_file_imports_and_shows(flat_map, tmp_path):
    runner = CliRunner()
    out = tmp_path / "example.h5"
    result = runner.invoke(cli, ["steps", "import", str(EXAMPLE), "--robot", "scarab2", "--map",
                                 str(flat_map[1]), "-o", str(out)])
    assert result.exit_code == 0, result.stderr
    png = tmp_path / "example.png"
    result = runner.invoke(cli, ["steps", "show", str(out), "--map", str(flat_map[1]), "-o", str(png)])
    assert result.exit_code == 0, result.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_invalid_row_exits_2_and_writes_nothing(flat_map, tmp_path):
    lines = EXAMPLE.read_text().splitlines()
    header = lines[1].split(",")
    row = lines[3].split(",")
    row[header.index("coxa_rf")] = "0.9"
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines[:3] + [",".join(row)] + lines[4:]) + "\n")
    out = tmp_path / "bad.h5"
    result = CliRunner().invoke(cli, ["steps", "import", str(bad), "--robot", "scarab2", "--map",
                                      str(flat_map[1]), "-o", str(out)])
    assert result.exit_code == 2
    assert "row 1: field 'coxa_rf'" in result.stderr
    assert not out.exists()


def test_gap_crossing_end_to_end(tmp_path):
    """Issue 5: `steps generate` crosses maps/gap_crossing.yaml; every configuration passes the
    independent validator and consecutive ones differ by one lift/touch-down or a body shift."""
    from legplan.robots import load_robot
    from legplan.stepseq import read_steps
    from legplan.terrain import load_map
    from legplan.validate import Validator

    runner = CliRunner()
    map_path, out = tmp_path / "map.h5", tmp_path / "steps.h5"
    spec = Path(__file__).parents[2] / "maps" / "gap_crossing.yaml"
    assert runner.invoke(cli, ["map", "build", str(spec), "-o", str(map_path), "-q"]).exit_code == 0
    result = runner.invoke(cli, ["steps", "generate", str(map_path), "--robot", "scarab2", "--start", "-0.6",
                                 "0", "0", "--goal", "0.6", "0", "0", "-o", str(out), "-q"])
    assert result.exit_code == 0, result.stderr  # exit 1 if a configuration missed a requirement
    seq = read_steps(out)
    assert len(seq) >= 80
    assert seq.q[0, 0] < -0.5 and seq.q[-1, 0] > 0.5  # from one side of the gap (x in [-0.2, 0.2]) to the other
    checks = Validator(load_robot("scarab2"), load_map(map_path)).check(seq.q, seq.stance, seq.footholds)
    assert checks.valid(foot_tolerance=1e-3).all()
    assert np.all(checks.com_margin > 0) and np.all(checks.clearance > 0)
    switched = np.abs(np.diff(seq.stance.astype(int), axis=0)).sum(axis=1)
    assert np.all(switched <= 1)
    held = seq.stance[1:] & seq.stance[:-1]  # legs in stance on both sides of a transition stay put
    moved = np.linalg.norm(np.nan_to_num(seq.footholds[1:] - seq.footholds[:-1]), axis=2)
    assert np.all(moved[held] == 0.0)


def test_generated_rows_missing_a_requirement_are_named(flat_map, tmp_path, monkeypatch):
    """The generator's configurations are judged against what it promises; a row that misses it is
    named on stderr and recorded, and the command exits 1 (here: the judge asks 10 cm clearance)."""
    from legplan.stepseq.generate import GenerateParams
    from legplan.validate.judge import Requirements

    monkeypatch.setattr(GenerateParams, "requirements", lambda self: Requirements(clearance=0.1))
    out = tmp_path / "steps.h5"
    result = CliRunner().invoke(cli, ["steps", "generate", str(flat_map[1]), "--robot", "scarab2",
                                      "--start", "-0.05", "0", "0", "--goal", "0.05", "0", "0", "-o", str(out), "-q"])
    assert result.exit_code == 1
    assert "row 0: clearance short by" in result.stderr
    with h5py.File(out, "r") as f:
        assert np.all(f["checks/shortfall_clearance"][()] > 0)


def test_generate_param_overrides_and_size_scaled_defaults(flat_map, generated, tmp_path):
    from legplan.artefacts import open_artefact, read_provenance

    def params_of(path):
        with open_artefact(path) as handle:
            return read_provenance(handle)["params"]

    defaults = params_of(generated)          # SCARAB II is the reference size: its tuned values
    assert (defaults["lift_height"], defaults["clearance"], defaults["com_margin"], defaults["reach_slack"]) \
        == (0.05, 0.02, 0.015, 0.015)
    out = tmp_path / "lifted.h5"
    args = ["steps", "generate", str(flat_map[1]), "--robot", "scarab2", "--start", "-0.05", "0", "0",
            "--goal", "0.05", "0", "0", "-q"]
    result = CliRunner().invoke(cli, [*args, "-o", str(out), "--param", "lift_height=0.07",
                                      "--param", "candidates=4"])
    assert result.exit_code == 0, result.stderr
    recorded = params_of(out)
    assert (recorded["lift_height"], recorded["candidates"], recorded["clearance"]) == (0.07, 4, 0.02)
    with h5py.File(out, "r") as f:                 # the apexes of the swing feet rise to the new height
        q, stance = f["q"][()], f["stance"][()].astype(bool)
    from legplan.robots import load_robot

    feet = load_robot("scarab2").foot_positions(q)
    assert feet[~stance][:, 2].max() > 0.06
    for bad, message in [("lift_height=-0.01", "field 'lift_height' must be >= 0"),
                         ("nope=1", "generator parameters: field 'nope' is unknown"),
                         ("candidates=2.5", "field 'candidates' must be a whole number"),
                         ("posture_weights=1", "'posture_weights' cannot be set")]:
        bad_out = tmp_path / "bad.h5"
        result = CliRunner().invoke(cli, [*args, "-o", str(bad_out), "--param", bad])
        assert result.exit_code == 2 and message in result.stderr, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1 and not bad_out.exists()


def test_size_scaled_defaults_follow_the_leg_length():
    from legplan.robots.sizing import REFERENCE_LEG_LENGTH
    from legplan.stepseq.generate import GenerateParams

    class Robot:
        leg_length = 2 * REFERENCE_LEG_LENGTH

    sized = GenerateParams(clearance=0.03).sized_for(Robot())
    assert (sized.lift_height, sized.com_margin, sized.reach_slack) == (0.1, 0.03, 0.03)
    assert sized.clearance == 0.03                  # a value given is kept
