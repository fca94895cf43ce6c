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
    b = write_motion(tmp_path / "b.h5", times=(0.5, 4.0, 12.0), success=(True, False, False), shift=1e-3)
    result = compare_artefacts(a, b)
    by_name = rows(result)
    assert not result.ok
    assert not by_name["item seconds"].ok and by_name["mean_time"].ok  # 4.67 -> 5.5 s: within 50%
    assert not by_name["steps/0001 success"].ok and by_name["steps/0001 success"].note == "slip too large"
    assert by_name["item control_points (array)"].b == pytest.approx(1e-3)
    assert not by_name["item control_points (array)"].ok
    loose = parse_tolerances(["*time*=200%", "seconds=200%", "control_points=0.01"])
    assert rows(compare_artefacts(a, b, loose))["item control_points (array)"].ok


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
    assert rows(result)["item timings/total"].tolerance == "0.5 + 100%"
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
    assert by_name["item seconds"].ok and by_name["item seconds"].tolerance == "0.5 + 100%"
    assert by_name["mean_time"].tolerance == "0.05 + 50%"
    c = write_motion(tmp_path / "c.h5", times=(0.02, 0.03, 30.0))
    assert not rows(compare_artefacts(a, c))["item seconds"].ok
