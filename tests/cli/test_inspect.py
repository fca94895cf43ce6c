"""`legplan` group, `--version`, `inspect` and the exit-code contract."""

import json

import numpy as np
from click.testing import CliRunner

from legplan import __version__
from legplan.artefacts import write_artefact, write_dataset, write_summary
from legplan.cli.main import cli


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_version_and_help():
    result = run("--version")
    assert result.exit_code == 0 and __version__ in result.output
    result = run("--help")
    assert result.exit_code == 0 and "inspect" in result.output


def test_inspect_prints_kind_datasets_and_summary(tmp_path):
    path = tmp_path / "map.h5"
    with write_artefact(path, "map", params={"resolution": 0.02}, seed=5) as handle:
        write_dataset(handle, "terrain/height", np.zeros((4, 6)), units="m")
        write_summary(handle, {"max_height": (0.25, "m")})
    result = run("inspect", path)
    assert result.exit_code == 0, result.output
    assert "map artefact, schema 1" in result.output
    assert "/terrain/height: 4x6 float64 [m]" in result.output
    assert "max_height  0.25 m" in result.output
    result = run("inspect", path, "--json")
    info = json.loads(result.stdout)
    assert info["kind"] == "map" and info["seed"] == 5
    assert info["summary"]["max_height"] == {"value": 0.25, "units": "m"}


def test_bad_inputs_exit_2_with_one_line(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("not hdf5")
    truncated = tmp_path / "cut.h5"
    with write_artefact(truncated, "map") as handle:
        write_dataset(handle, "x", np.arange(10000.0))
    truncated.write_bytes(truncated.read_bytes()[:3000])
    for path in (text, truncated, tmp_path / "missing.h5"):
        result = run("inspect", path)
        assert result.exit_code == 2
        lines = [line for line in result.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("Error:") and str(path.name) in lines[0]
        assert "Traceback" not in result.output


def test_usage_error_exits_2():
    assert run("inspect").exit_code == 2
    assert run("no-such-command").exit_code == 2


def test_error_line_is_never_wrapped_nor_read_as_markup(tmp_path):
    path = tmp_path / ("[bold]" + "x" * 150 + ".h5")
    result = run("inspect", path)
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and str(path) in lines[0]
