"""Progress on stderr: `ProgressLines` (logs) by its clock, and every command's progress through
`progress_bar` when stderr is a file (lines with an ETA, silenced by -q)."""

from pathlib import Path

from click.testing import CliRunner

from legplan.cli.console import ProgressLines
from legplan.cli.main import cli

MAPS = Path(__file__).resolve().parents[2] / "maps"


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def _lines(interval=10.0):
    clock, written = Clock(), []
    return ProgressLines("planning steps", written.append, interval=interval, clock=clock), clock, written


def test_first_update_then_one_line_per_interval_with_eta():
    lines, clock, written = _lines()
    lines.update(0, 40, "")
    assert written == ["planning steps: 0/40 (0 %), elapsed 0:00:00, ETA ?"]
    clock.now += 5
    lines.update(4, 40, "step 3")
    assert len(written) == 1  # within the interval: no line
    clock.now += 5
    lines.update(10, 40, "step 9")
    # 10 items in 10 s since the first update: 30 left take 30 s
    assert written[-1] == "planning steps: 10/40 (25 %), elapsed 0:00:10, ETA 0:00:30, step 9"


def test_eta_counts_from_the_first_update_not_from_resumed_items():
    lines, clock, written = _lines()
    clock.now += 60  # loading before the first update
    lines.update(30, 40, "30 resumed")
    assert written[-1].endswith("ETA ?, 30 resumed")
    clock.now += 20
    lines.update(35, 40)
    assert "ETA 0:00:20" in written[-1] and "elapsed 0:01:20" in written[-1]


def test_tick_writes_while_no_update_arrives_and_close_writes_the_last_state():
    lines, clock, written = _lines()
    lines.tick()
    assert written == []  # nothing before the first update
    lines.update(1, 3)
    clock.now += 9
    lines.tick()
    assert len(written) == 1
    clock.now += 2
    lines.tick()
    assert len(written) == 2 and written[-1].startswith("planning steps: 1/3 (33 %), elapsed 0:00:11")
    lines.update(3, 3, "0 failed")
    lines.close()
    assert written[-1] == "planning steps: 3/3 (100 %), elapsed 0:00:11, done, 0 failed"
    lines.close()
    assert len(written) == 3  # the last state is not repeated


def test_a_command_writes_progress_lines_to_a_log_and_none_with_quiet(tmp_path):
    result = CliRunner().invoke(cli, ["map", "build", str(MAPS / "single_pallet.yaml"), "-o", str(tmp_path / "a.h5")])
    assert result.exit_code == 0, result.output
    progress = [line for line in result.stderr.splitlines() if line.startswith("building SDF: ")]
    assert progress and "ETA" in progress[0] and progress[-1].split(", ")[2] == "done"
    quiet = CliRunner().invoke(cli, ["map", "build", str(MAPS / "single_pallet.yaml"), "-o", str(tmp_path / "b.h5"),
                                     "-q"])
    assert quiet.exit_code == 0 and quiet.stderr == ""
