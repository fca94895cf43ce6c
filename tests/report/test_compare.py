"""compare_artefacts: summary rows and per-item results against tolerances."""

import pytest
from fake_artefacts import write_map, write_motion

from legplan.errors import ArtefactError, LegplanError
from legplan.report.compare import Tolerance, compare_artefacts, parse_tolerances


def rows(result):
    return {row.name: row for row in result.rows}


def test_identical_content_is_within_tolerance(tmp_path):
    a, b = write_motion(tmp_path / "a.h5"), write_motion(tmp_path / "b.h5")
    result = compare_artefacts(a, b)
    assert result.ok and result.kind == "motion"
    assert rows(result)["items succeeded"].a == "2/3"
    assert rows(result)["item control_points (array)"].b == 0.0


def test_time_within_default_relative_tolerance_violation_not(tmp_path):
    a = write_motion(tmp_path / "a.h5")
    b = write_motion(tmp_path / "b.h5", times=(0.6, 1.8, 14.0), slips=(1e-7, 2e-7, 3.1e-3))
    by_name = rows(compare_artefacts(a, b))
    assert by_name["mean_time"].ok and by_name["item seconds"].ok
    assert not by_name["worst_violation"].ok and not by_name["item dense/foot_slip"].ok
    assert "1 of 3 items differ, first steps/0002" in by_name["item dense/foot_slip"].note
    relaxed = compare_artefacts(a, b, parse_tolerances(["worst_violation=0.001", "*foot_slip=10%"]))
    assert relaxed.ok


def test_times_beyond_tolerance_success_flip_and_trajectory_shift(tmp_path):
    a = write_motion(tmp_path / "a.h5")
    b = write_motion(tmp_path / "b.h5", times=(0.5, 5.0, 12.0), success=(True, False, False), shift=1e-3)
    result = compare_artefacts(a, b, timings=True)
    by_name = rows(result)
    assert not result.ok
    assert not by_name["item seconds"].ok and by_name["mean_time"].ok  # 4.67 -> 5.83 s: within 50%
    assert not by_name["steps/0001 success"].ok and by_name["steps/0001 success"].note == "slip too large"
    assert by_name["item control_points (array)"].b == pytest.approx(1e-3)
    assert not by_name["item control_points (array)"].ok
    loose = parse_tolerances(["*time*=200%", "seconds=200%", "control_points=0.01"])
    assert rows(compare_artefacts(a, b, loose, timings=True))["item control_points (array)"].ok


def test_missing_items_and_summary_rows(tmp_path):
    a = write_motion(tmp_path / "a.h5")
    b = write_motion(tmp_path / "b.h5", times=(0.5, 1.5), slips=(1e-7, 2e-7), success=(True, True))
    by_name = rows(compare_artefacts(a, b))
    assert not by_name["items in one artefact only"].ok
    assert by_name["items in one artefact only"].note == "steps/0002"


def test_different_kinds_refused(tmp_path):
    with pytest.raises(ArtefactError, match="is a 'map' artefact, cannot compare"):
        compare_artefacts(write_motion(tmp_path / "a.h5"), write_map(tmp_path / "m.h5"))


def test_parse_tolerances():
    assert parse_tolerances(["t=20%", "v=0.5"]) == {"t": Tolerance(0.0, 0.2), "v": Tolerance(0.5, 0.0)}
    for bad in ("noequals", "=1", "x=abc", "x=-1"):
        with pytest.raises(LegplanError, match="--tol"):
            parse_tolerances([bad])
    assert Tolerance(0, 0).holds(float("nan"), float("nan")) and not Tolerance(1, 1).holds(1.0, float("nan"))


def test_item_datasets_in_seconds_are_times_and_metrics_of_some_items_only(tmp_path):
    from legplan.artefacts import write_artefact, write_dataset

    def write(path, total, extra):
        with write_artefact(path, "traj") as f:
            for i in range(2):
                g = f.create_group(f"tasks/{i:04d}")
                g.attrs["success"] = True
                write_dataset(g, "timings/total", total, units="s")
                if i == 0:
                    write_dataset(g, "violations/swing", extra)  # a constraint only the first task has
        return path

    result = compare_artefacts(write(tmp_path / "a.h5", 0.10, 1e-4), write(tmp_path / "b.h5", 0.12, 1e-4))
    assert result.ok
    assert rows(result)["item timings/total"].tolerance == "0.5 + 50%"
    assert rows(result)["item violations/swing"].note == "largest at tasks/0000"


def test_dataset_missing_in_one_artefact_is_a_difference(tmp_path):
    import h5py

    a, b = write_motion(tmp_path / "a.h5"), write_motion(tmp_path / "b.h5")
    with h5py.File(b, "a") as f:
        del f["steps/0000/control_points"]
    result = compare_artefacts(a, b)
    assert not result.ok
    missing = rows(result)["item control_points missing"]
    assert (missing.a, missing.b, missing.note) == (0, 1, "missing in B at steps/0000")
    assert not rows(compare_artefacts(b, a))["item control_points missing"].ok


def test_item_clock_values_have_their_own_tolerance(tmp_path):
    """One step's wall-clock time may double under load (0.02 -> 0.2 s: beyond the summary's
    0.05 s + 50 %) without being a regression; the summary mean keeps the tighter default."""
    a = write_motion(tmp_path / "a.h5", times=(0.02, 0.03, 12.0))
    b = write_motion(tmp_path / "b.h5", times=(0.2, 0.03, 12.0))
    by_name = rows(compare_artefacts(a, b))
    assert by_name["item seconds"].ok and by_name["item seconds"].tolerance == "0.5 + 50%"
    assert by_name["mean_time"].tolerance == "0.05 + 50%"
    c = write_motion(tmp_path / "c.h5", times=(0.02, 0.03, 30.0))
    assert not rows(compare_artefacts(a, c))["item seconds"].ok


def test_relative_tolerance_is_symmetric(tmp_path):
    """|b - a| <= abs + rel * max(|a|, |b|): swapping A and B gives the same rows' verdicts; a
    summary time of 46.45 s against 7.56 s is not within 50 %."""
    a = write_motion(tmp_path / "a.h5", times=(7.56, 7.56, 7.56), slips=(1.0, 2.0, 3.0))
    b = write_motion(tmp_path / "b.h5", times=(46.45, 46.45, 30.0), slips=(1.5, 2.0, 4.0))
    tol = parse_tolerances(["*foot_slip=40%", "worst_violation=30%"])
    forward, backward = compare_artefacts(a, b, tol, timings=True), compare_artefacts(b, a, tol, timings=True)
    assert [(r.name, r.ok) for r in forward.rows] == [(r.name, r.ok) for r in backward.rows]
    assert not rows(forward)["mean_time"].ok
    # 3 -> 4 is within 30 % of 4 (not of 3); 1 -> 1.5 is within 40 % of 1.5 (not of 1)
    assert rows(forward)["worst_violation"].ok and rows(forward)["item dense/foot_slip"].ok
    assert Tolerance(0.0, 0.5).holds(10.0, 20.0) and Tolerance(0.0, 0.5).holds(20.0, 10.0)
    assert not Tolerance(0.0, 0.4).holds(10.0, 20.0) and not Tolerance(0.0, 0.4).holds(20.0, 10.0)


def test_clock_values_are_out_of_the_verdict_unless_timings(tmp_path):
    """Two runs that differ only in wall-clock readings (summary times, item seconds, timings/*)
    compare equal by default; `timings=True` or an override naming the metric judges them."""
    a = write_motion(tmp_path / "a.h5", times=(0.5, 1.5, 12.0))
    b = write_motion(tmp_path / "b.h5", times=(5.0, 15.0, 120.0))
    result = compare_artefacts(a, b)
    assert result.ok
    by_name = rows(result)
    assert not by_name["mean_time"].judged and not by_name["mean_time"].ok
    assert "not judged" in by_name["item seconds"].note
    assert by_name["worst_violation"].judged
    assert not compare_artefacts(a, b, timings=True).ok
    named = compare_artefacts(a, b, parse_tolerances(["mean_time=20%"]))
    assert not named.ok and rows(named)["mean_time"].judged and not rows(named)["item seconds"].judged


def test_which_names_are_clock_values():
    from legplan.report.compare import is_clock

    for name in ("seconds", "timings/total", "tasks/0001/timings/solve", "median_seconds", "mean_time",
                 "median_time", "mean_time_below_50s", "median_planning_time", "max_solve_time",
                 "median_first_iteration_time", "median_time_per_expansion", "compute_seconds"):
        assert is_clock(name), name
    for name in ("median_duration", "total_time", "running_time", "t", "dt", "phases/durations",
                 "worst_violation", "median_total_time"):
        assert not is_clock(name), name
