"""`legplan nav simulate` / `nav refine` end to end on the small flat map."""

from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from legplan.cli.main import cli

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def flat_map(tmp_path_factory):
    path = tmp_path_factory.mktemp("nav") / "flat.h5"
    result = CliRunner().invoke(cli, ["map", "build", str(ROOT / "maps" / "flat.yaml"), "-o", str(path), "-q"])
    assert result.exit_code == 0, result.output
    return path


def test_simulate_writes_run(flat_map, tmp_path):
    out = tmp_path / "run.h5"
    result = CliRunner().invoke(cli, ["nav", "simulate", str(flat_map), "--start", "-1,0,0", "--goal", "0.5,0.3",
                                      "--outer", "2", "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out) as f:
        sim = f["simulation"]
        assert sim.attrs["success"] and sim.attrs["collisions"] == 0
        assert sim["state"].shape[1] == 6 and len(sim["command"]) == len(sim["compute_seconds"])


def test_simulate_bad_pose_is_exit_2(flat_map, tmp_path):
    result = CliRunner().invoke(cli, ["nav", "simulate", str(flat_map), "--start", "a,b", "--goal", "1,1",
                                      "-o", str(tmp_path / "x.h5")])
    assert result.exit_code == 2 and "--start" in result.stderr
    assert not (tmp_path / "x.h5").exists()


def test_refine_adds_teb_group(flat_map, tmp_path):
    nav = tmp_path / "nav.h5"
    result = CliRunner().invoke(cli, ["nav", "search", str(flat_map), "--start", "-1", "-1", "--goal", "1", "0.8",
                                      "-o", str(nav), "-q"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "teb.h5"
    result = CliRunner().invoke(cli, ["nav", "refine", str(flat_map), str(nav), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out) as f:
        teb = f["queries/0000/teb"]
        assert teb["poses"].shape[1] == 3 and len(teb["dt"]) == len(teb["poses"]) - 1
        assert teb.attrs["max_violation"] <= 0.05 and teb.attrs["total_time"] > 0
        assert "segments" in f["queries/0000"]  # the search group is kept
