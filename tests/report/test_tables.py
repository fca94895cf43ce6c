"""The report's tables and figures say what the artefact holds: checks with their tolerances, NaN
summaries as undefined, the refinement's numbers for a refined nav artefact, each histogram once."""

import h5py
import numpy as np
from fake_artefacts import write_map, write_motion, write_traj

from legplan.artefacts import write_artefact, write_dataset, write_summary
from legplan.report import write_report
from legplan.report.checks import check_rows
from legplan.report.kinds import nav_queries


def _add_checks(traj, tasks):
    """Copy task 0 to `tasks` tasks, each with a judged clearance (lower bound 0.0 m) and a judged
    dynamics residual (upper bound 1 N), the last task failing the clearance."""
    with h5py.File(traj, "a") as f:
        for k in range(1, tasks):
            f.copy(f["tasks/0000"], f"tasks/{k:04d}")
        for k in range(tasks):
            check = f[f"tasks/{k:04d}"].create_group("check")
            clearance = -0.004 if k == tasks - 1 else 0.01 * (k + 1)
            d = check.create_dataset("min_clearance", data=clearance)
            d.attrs.update(units="m", tolerance=0.0, bound="lower", passed=clearance >= 0)
            d = check.create_dataset("newton_euler", data=0.1 * (k + 1))
            d.attrs.update(units="N", tolerance=1.0, bound="upper", passed=True)
            check.create_dataset("recorded_only", data=3.0).attrs["units"] = "s"


def test_check_table_shows_each_tolerance_and_the_failing_tasks(tmp_path, flat_terrain):
    from legplan.terrain.terrain_map import save_map

    flat = tmp_path / "flat.h5"
    save_map(flat_terrain, flat)
    traj = write_traj(tmp_path / "traj.h5", flat, samples=20)
    _add_checks(traj, 3)
    rows = {row["metric"]: row for row in check_rows(traj)}
    assert rows["min_clearance"]["worst"] == -0.004 and rows["min_clearance"]["failing"] == ["0002"]
    assert rows["newton_euler"]["worst"] == np.float64(0.1 * 3) and rows["newton_euler"]["passed"] == 3
    assert rows["recorded_only"]["judged"] == 0
    write_report([traj], tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    table = page.split('<table class="checks verdict">')[1].split("</table>")[0]
    assert "≥ 0" in table and "≤ 1" in table and "2/3 passed (failing: 0002)" in table
    assert "3/3 passed" in table and "recorded, not judged" in table


def test_nan_summary_is_shown_as_undefined(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    motion = write_motion(tmp_path / "motion.h5", inputs=[map_path])
    with h5py.File(motion, "a") as f:
        del f["summary"]
    with h5py.File(motion, "a") as f:
        write_summary(f, {"steps_planned": 3, "mean_time_1s_to_50s": (float("nan"), "s")})
    write_report([motion], tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    assert ">nan<" not in page
    assert '<td>mean_time_1s_to_50s</td><td class="num">n/a</td>' in page and "n/a: not defined" in page


def test_each_time_histogram_is_drawn_once(tmp_path, robot_motion):
    """A motion with a robot and a map: the Fig. 4 histograms are the tracks figure's; the steps
    figure keeps only the slip; Fig. 4 (b) is not a copy of (a) when every step is under 10 s."""
    map_path, motion = robot_motion
    with h5py.File(motion, "a") as f:
        for name in f["steps"]:
            write_dataset(f["steps"][name], "dense/foot_slip", 1e-4, units="m")
    result = write_report([motion], tmp_path / "rep")
    captions = {f.filename: f.caption for f in result.sections[0].figures}
    assert "histogram" not in captions["00-motion-steps.png"] and "foot_slip" in captions["00-motion-steps.png"]
    assert "00-motion-tracks.png" in captions


def test_refined_nav_figure_shows_the_refinement_numbers(tmp_path):
    path = tmp_path / "refine.h5"
    with write_artefact(path, "nav") as f:
        for k, (search, teb) in enumerate([(0.5, 0.02), (0.7, 0.03)]):
            g = f.create_group(f"queries/{k:04d}")
            g.attrs.update(success=True, reason="", planning_time=search, min_clearance=0.3)
            t = g.create_group("teb")
            t.attrs.update(seconds=teb, min_clearance=0.12, total_time=2.0, effort=1.0)
        write_summary(f, {"median_teb_seconds": (0.025, "s")})
    caption = nav_queries(path, tmp_path / "q.png")
    assert "TEB refinement time ('seconds') histogram" in caption
    assert "TEB refinement 'min_clearance'" in caption
