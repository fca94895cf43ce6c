"""`legplan report` end to end on fake artefacts."""

import sys
from pathlib import Path

from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parents[1] / "report"))
from fake_artefacts import write_map  # noqa: E402

from legplan.cli.main import cli  # noqa: E402


def test_report_writes_index_and_refuses_existing(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    out = tmp_path / "rep"
    result = CliRunner().invoke(cli, ["report", str(map_path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "cells_x" in (out / "index.html").read_text()
    assert "1 artefacts, 1 figures" in result.stderr
    again = CliRunner().invoke(cli, ["report", str(map_path), "-o", str(out)])
    assert again.exit_code == 2 and "output exists (use --overwrite" in again.stderr


def test_report_bad_input_exit_2(tmp_path):
    result = CliRunner().invoke(cli, ["report", str(tmp_path / "none.h5"), "-o", str(tmp_path / "r")])
    assert result.exit_code == 2 and "none.h5: no such file" in result.stderr
    assert not (tmp_path / "r").exists()
