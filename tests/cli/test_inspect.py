"""`legplan` group, `--version`, `inspect` and the exit-code contract."""

import json
from pathlib import Path

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
    assert "max_height  0.25 m" in result.output
    assert "/terrain/height: 4x6 float64 [m]" in run("inspect", path, "--full").output
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


def test_inspect_prints_the_summary_first_and_the_datasets_with_full(tmp_path):
    path = tmp_path / "motion.h5"
    with write_artefact(path, "motion", params={"samples": 30}) as handle:
        for i in range(40):
            write_dataset(handle, f"steps/{i:04d}/control_points", np.zeros((4, 3)), units="m")
        write_dataset(handle, "terrain/height", np.zeros((4, 6)), units="m")
        write_summary(handle, {"steps_planned": 40})
    short = run("inspect", path)
    lines = short.stdout.splitlines()
    assert short.exit_code == 0 and lines[1] == "  summary:" and lines[2].split() == ["steps_planned", "40"]
    assert lines[-1] == "  datasets: 41 (/steps 40, /terrain 1); params, inputs and datasets: --full"
    assert len(lines) < 10 and "control_points" not in short.stdout
    full = run("inspect", path, "--full").stdout
    assert full.startswith(short.stdout.rsplit("  datasets:", 1)[0])  # the same head, then the rest
    assert '"samples": 30' in full and full.count("/control_points: 4x3 float64 [m]") == 40


def test_a_closed_output_pipe_ends_any_command_quietly(tmp_path):
    """`legplan ... | head`: the reader gone, the command exits 141 (128 + SIGPIPE) without a
    message, for a command's own output, a long output and the help text alike."""
    import os
    import subprocess
    import sys

    path = tmp_path / "map.h5"
    with write_artefact(path, "map") as handle:
        for i in range(3000):  # more than a pipe's buffer
            write_dataset(handle, f"layers/{i:05d}", np.zeros(2), units="m")
    for args in (["inspect", str(path), "--full"], ["inspect", str(path)], ["robot", "show", "scarab2"],
                 ["step", "plan", "--help"]):
        read, write = os.pipe()
        os.close(read)  # the reader has gone before the first line
        done = subprocess.run([str(Path(sys.executable).parent / "legplan"), *args], stdout=write, stderr=subprocess.PIPE,
                              text=True, timeout=120)
        os.close(write)
        assert (done.returncode, done.stderr) == (141, ""), args
