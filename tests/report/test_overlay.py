"""Ours and OMPL overlaid in one comparison when both motions are given to `report`."""

import h5py
import numpy as np
from fake_artefacts import write_map, write_motion

from legplan.report import write_report
from legplan.report.overlay import overlay_groups, planner_label


def _baseline(path, map_path):
    write_motion(path, times=(2.0, 9.0, 30.0), slips=(0.0, 0.0, 0.0), success=(True, False, False), inputs=[map_path])
    with h5py.File(path, "a") as f:
        for name in f["steps"]:
            f["steps"][name].attrs["planner"] = "ompl-rrtconnect"
    return path


def test_ours_and_ompl_in_one_table_and_figure(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    ours = write_motion(tmp_path / "motion.h5", inputs=[map_path])
    ompl = _baseline(tmp_path / "ompl.h5", map_path)
    assert planner_label(ompl) == "ompl-rrtconnect"
    result = write_report([map_path, ours, ompl], tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    assert page.count('<section id="compare-motion">') == 1 and (tmp_path / "rep" / "compare-motion.png").is_file()
    table = page.split('<table class="overlay">')[1].split("</table>")[0]
    rows = [row for row in table.split("<tr>")[2:]]
    assert len(rows) == 2 and "ompl-rrtconnect" in rows[1]
    cells = [[c.split(">", 1)[1] for c in row.split("</td>")[:-1]] for row in rows]
    assert cells[0][1:5] == ["3", "2", "1.5", "12"]       # ours: 3 steps, 2 succeeded, median and worst time
    assert cells[1][1:5] == ["3", "1", "9", "30"]         # the baseline's
    assert float(cells[0][5]) == 2e-7                      # worst foot slip of the succeeded steps
    assert result.failures == 0


def test_one_artefact_of_a_kind_is_not_compared(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    paths = [map_path, write_motion(tmp_path / "motion.h5", inputs=[map_path])]
    assert overlay_groups(paths, ["map", "motion"]) == {}
    write_report(paths, tmp_path / "rep")
    assert "compare-motion" not in (tmp_path / "rep" / "index.html").read_text()
