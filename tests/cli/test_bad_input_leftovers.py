"""Concurrent runs to one output (issue 35 class 5) and the leftovers of the first audit (class 6):
each a one-line refusal naming the file and field (exit 2, nothing written), or, for two
`--overwrite` runs to one output, both succeed and the last one's artefact stays."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
from bad_input_support import EXAMPLE_STEPS, assert_refused, few, invoke, mutated, with_value
from hypothesis import given
from hypothesis import strategies as st

from legplan.batch.workfile import WorkFile, work_path

ROOT = Path(__file__).parents[2]
LEGPLAN = str(Path(sys.executable).parent / "legplan")


# Class 5: concurrency.
def test_a_second_overwriting_run_starts_its_own_work_file_and_leaves_the_firsts(tmp_path):
    output = tmp_path / "out.h5"
    first = WorkFile.open(output, {"stage": "x"}, [], [1, 2], resume=False, overwrite=True)
    second = WorkFile.open(output, {"stage": "x"}, [], [1, 2], resume=False, overwrite=True)  # no lock error
    first.add(0, {"success": True})   # the first keeps writing its own (now unlinked) file
    second.add(1, {"success": True})
    assert [r["success"] for r in first.records()] == [True]
    first.remove()                    # does not delete the second run's work file
    assert work_path(output).exists()
    second.remove()
    assert not work_path(output).exists()


def test_two_overwriting_dyn_plans_to_one_output_both_succeed_and_the_last_wins(inputs, tmp_path):
    output = tmp_path / "traj.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def start(goal: str):
        return subprocess.Popen([LEGPLAN, "dyn", "plan", str(inputs["map"]),
                                 "--start", "0", "0", "0", "--goal", goal, "0", "0", "--strides", "2",
                                 "--duration", "1.6", "-o", str(output), "--overwrite", "-q"],
                                env=env, stderr=subprocess.PIPE, text=True)

    first = start("0.3")
    time.sleep(0.5)
    second = start("0.2")
    errors = [p.communicate(timeout=300)[1] for p in (first, second)]
    assert [first.returncode, second.returncode] == [0, 0], errors
    assert errors == ["", ""]
    with h5py.File(output, "r") as f:
        assert f.attrs["legplan_kind"] == "traj"
    assert not work_path(output).exists()
    assert not [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# Class 6: leftovers.
@few(10)
@given(rows=st.lists(st.integers(0, 2), min_size=2, max_size=3, unique=True),
       column=st.sampled_from(["x", "y", "z", "femur_lf", "tibia_rm"]))
def test_steps_import_of_several_bad_rows_is_one_line(inputs, tmp_path_factory, rows, column):
    tmp_path = tmp_path_factory.mktemp("rows")
    lines = EXAMPLE_STEPS.read_text().splitlines()
    header = lines[1].split(",")
    for row in rows:
        cells = lines[2 + row].split(",")
        cells[header.index(column)] = "abc"
        lines[2 + row] = ",".join(cells)
    bad = tmp_path / "steps.csv"
    bad.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.h5"
    line = assert_refused(invoke(["steps", "import", bad, "--robot", "scarab2", "--map", inputs["map"], "-o", out]),
                          "steps.csv", f"row {min(rows)}", f"'{column}'", "more errors", output=out)
    assert f"in {len(rows)} rows" in line


def test_a_steps_json_that_is_a_top_level_list_is_refused(inputs, tmp_path):
    lines = EXAMPLE_STEPS.read_text().splitlines()[1:]
    header = lines[0].split(",")
    records = [dict(zip(header, (float(v) if v else None for v in line.split(",")), strict=True)) for line in lines[1:]]
    bad = tmp_path / "steps.json"
    bad.write_text(json.dumps(records))
    out = tmp_path / "out.h5"
    assert_refused(invoke(["steps", "import", bad, "--robot", "scarab2", "--map", inputs["map"], "-o", out]),
                   "steps.json", "'configurations'", "got a list", output=out)


def test_a_legplan_robots_folder_that_does_not_exist_is_refused(inputs, tmp_path, monkeypatch):
    monkeypatch.setenv("LEGPLAN_ROBOTS", str(tmp_path / "no-such-folder"))
    out = tmp_path / "out.h5"
    for args in (["robot", "list"], ["steps", "import", EXAMPLE_STEPS, "--robot", "scarab2", "--map", inputs["map"],
                                     "-o", out]):
        assert_refused(invoke(args), "LEGPLAN_ROBOTS", "no-such-folder", "is not a folder", output=out)


@pytest.mark.parametrize("case", ["no p", "NaN p"])
def test_nav_refine_of_a_nav_file_without_p_or_with_nan_is_refused(inputs, tmp_path, case):
    change = (lambda a: None) if case == "no p" else with_value(7, float("nan"))
    bad = mutated(inputs["nav"], tmp_path / "bad_nav.h5", "queries/0000/p", change)
    out = tmp_path / "refined.h5"
    field = "missing dataset '/queries/0000/p'" if case == "no p" else "'/queries/0000/p' holds NaN"
    assert_refused(invoke(["nav", "refine", inputs["map"], bad, "-o", out]), "bad_nav.h5", field, output=out)


def test_report_of_a_motion_without_control_points_is_refused(inputs, tmp_path):
    bad = mutated(inputs["motion"], tmp_path / "bad_motion.h5", "steps/0000/control_points", lambda a: None)
    out = tmp_path / "report"
    assert_refused(invoke(["report", bad, "-o", out]), "bad_motion.h5", "'/steps/0000/control_points'", output=out)


def test_a_swallowed_interrupt_prints_no_exception_ignored_traceback(monkeypatch):
    import signal

    from legplan import interrupts

    reported = []  # what would print "Exception ignored ..."
    monkeypatch.setattr(sys, "unraisablehook", lambda report: reported.append(type(report.exc_value)))

    class RaisesInFinalizer:  # what h5py's C callbacks do with the signal's exception
        def __init__(self, error):
            self.error = error

        def __del__(self):
            raise self.error

    with interrupts.handle_interrupts():
        RaisesInFinalizer(KeyboardInterrupt())  # no signal came: reported as ever
        interrupts._received.append(signal.SIGINT)
        RaisesInFinalizer(KeyboardInterrupt())  # the signal's own exception: silent, raised again below
        RaisesInFinalizer(ValueError())         # anything else: reported
        with pytest.raises(KeyboardInterrupt):
            interrupts.raise_if_interrupted()
    RaisesInFinalizer(KeyboardInterrupt())      # outside the block: reported
    assert reported == [KeyboardInterrupt, ValueError, KeyboardInterrupt]


def test_map_build_interrupted_while_writing_prints_one_line(tmp_path):
    spec = tmp_path / "big.yaml"
    spec.write_text("name: big\nresolution: 0.02\nextent: {x: [-3, 3], y: [-3, 3]}\n"
                    "primitives: [{type: box, center: [0, 0], size: [1, 1], height: 0.5}]\n")
    out = tmp_path / "map.h5"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen([LEGPLAN, "map", "build", str(spec), "-o", str(out)],
                               env=env, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not any(p.name.endswith(".tmp") for p in tmp_path.iterdir()):
        time.sleep(0.005)  # the temporary appears when the write starts
    process.send_signal(2)
    _, err = process.communicate(timeout=120)
    assert process.returncode in (0, 130), err  # 0: the write ended before the signal came
    assert "Exception ignored" not in err and "Traceback" not in err, err
    assert out.exists() == (process.returncode == 0)


def test_an_unwritable_output_folder_is_named_not_the_temporary(inputs, tmp_path):
    # /proc refuses new files even to root (a read-only folder does not stop root)
    for args, out in ((["map", "build", ROOT / "maps" / "flat.yaml"], "/proc/legplan_test_map.h5"),
                      (["dyn", "show", inputs["traj"]], "/proc/legplan_test_traj.png"),
                      (["nav", "search", inputs["map"], "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5"],
                       "/proc/legplan_test_nav.h5")):
        line = assert_refused(invoke([*args, "-o", out, "-q"]), out, "cannot write the output")
        assert ".tmp" not in line and ".work" not in line, line


def test_a_byte_order_mark_in_a_csv_is_not_part_of_the_first_field(inputs, tmp_path):
    table = tmp_path / "tasks.csv"
    table.write_bytes("\ufeffstart_x,start_y,start_yaw,goal_x,goal_y,goal_yaw\n0,0,0,0.3,0,nan\n".encode())
    out = tmp_path / "out.h5"
    line = assert_refused(invoke(["dyn", "plan", inputs["map"], "--tasks", table, "-o", out]), "field 'goal_yaw'",
                          output=out)
    assert "\ufeff" not in line
    steps = tmp_path / "steps.csv"
    steps.write_bytes(b"\xef\xbb\xbf" + EXAMPLE_STEPS.read_bytes())
    result = invoke(["steps", "import", steps, "--robot", "scarab2", "--map", inputs["map"], "-o", tmp_path / "s.h5"])
    assert result.exit_code == 0, result.stderr
