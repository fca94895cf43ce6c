"""`legplan nav search|show`: single query, batch with a failing query (exit 1), bad input (exit 2)."""

import h5py
import numpy as np
from click.testing import CliRunner

from legplan.artefacts import open_artefact, read_summary
from legplan.cli.main import cli
from legplan.nav import Trajectory
from pictures import pixels, share


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_single_query_with_start_velocity_and_show(tmp_path, block_map):
    map_path = block_map
    out = tmp_path / "nav.h5"
    result = run("nav", "search", map_path, "--start", 1, 2, "--start-vel", 0.4, 0, "--goal", 7, 2,
                 "-o", out, "--param", "weight=2", "-q")
    assert result.exit_code == 0, result.output
    with open_artefact(out, kind="nav") as handle:
        query = handle["queries/0000"]
        assert query.attrs["success"] and query.attrs["planner"] == "kinoastar"
        trajectory = Trajectory(query["segments"][()])
        np.testing.assert_allclose(trajectory.evaluate([0.0])[1][0], [0.4, 0.0])
        assert query.attrs["duration"] == trajectory.duration
        assert query.attrs["min_clearance"] >= 0.2
        assert query["p"].attrs["units"] == "m" and query["a"].attrs["units"] == "m/s^2"
        summary = read_summary(handle)
        assert summary["succeeded"][0] == 1 and summary["median_planning_time"][1] == "s"
    png = tmp_path / "nav.png"
    result = run("nav", "show", out, "--map", map_path, "-o", png)
    assert result.exit_code == 0, result.output
    image = pixels(png)   # the query's path (C0) over the lethal block (black)
    assert share(image, "tab:blue") > 2e-4 and share(image, "black") > 0.01


def test_batch_with_a_failing_query_exits_1_and_records_reasons(tmp_path, block_map):
    map_path = block_map
    queries = tmp_path / "queries.csv"
    queries.write_text("start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                       "1,1,0,0,7,4,0,0\n"
                       "4,2,0,0,7,4,0,0\n"
                       "1,4,0,0,6,1,0,0\n")
    for planner in ("kinoastar", "astar"):
        out = tmp_path / f"{planner}.h5"
        result = run("nav", "search", map_path, "--queries", queries, "--planner", planner,
                     "-o", out, "--param", "weight=2")
        assert result.exit_code == 1, result.output
        assert "0001: failed: start in collision" in result.stderr
        with h5py.File(out) as handle:
            assert [bool(handle[f"queries/000{i}"].attrs["success"]) for i in range(3)] == \
                [True, False, True]
            assert "segments" not in handle["queries/0001"]
            assert handle["queries/0000"].attrs["planner"] == planner
            assert ("waypoints" in handle["queries/0000"]) == (planner == "astar")
            assert read_summary(handle)["succeeded"][0] == 2


def test_bad_inputs_exit_2_without_output(tmp_path, block_map):
    map_path = block_map
    out = tmp_path / "nav.h5"
    result = run("nav", "search", map_path, "--start", 1, 1, "-o", out)
    assert result.exit_code == 2 and "--goal" in result.output
    result = run("nav", "search", map_path, "--start", 1, 1, "--goal", 5, 1, "--param", "bogus=1",
                 "-o", out)
    assert result.exit_code == 2 and "nav parameters: field 'bogus' is unknown" in result.output
    bad = tmp_path / "q.csv"
    bad.write_text("start_x,start_y\n1,2\n")
    result = run("nav", "search", map_path, "--queries", bad, "-o", out)
    assert result.exit_code == 2 and "missing column 'start_vx'" in result.output
    assert not out.exists()


def test_queries_from_a_movingai_scen_file(tmp_path, block_map):
    map_path = block_map
    scen = tmp_path / "block.map.scen"
    scen.write_text("version 1\n3\tblock.map\t80\t50\t10\t30\t70\t45\t6.0\n")
    out = tmp_path / "nav.h5"
    result = run("nav", "search", map_path, "--queries", scen, "-o", out, "-q")
    assert result.exit_code == 0, result.output
    with open_artefact(out, kind="nav") as handle:
        query = handle["queries/0000"]
        # row 30 from the top of 50 rows is grid row 19; row 45 is grid row 4 (cell centres)
        np.testing.assert_allclose(query.attrs["start"], [1.05, 1.95, 0, 0])
        np.testing.assert_allclose(query.attrs["goal"], [7.05, 0.45, 0, 0])
    result = run("nav", "search", map_path, "--queries", scen, "--robot", "jueying_mini",
                 "-o", tmp_path / "x.h5", "--start", 1, 1)
    assert result.exit_code == 2 and not (tmp_path / "x.h5").exists()


def test_a_batch_with_two_jobs_is_searched_by_workers_forked_from_the_command(tmp_path, block_map):
    from jobs_support import assert_forked_from_command

    queries = tmp_path / "queries.csv"
    queries.write_text("start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                       "1,1,0,0,7,4,0,0\n4,2,0,0,7,4,0,0\n1,4,0,0,6,1,0,0\n")
    argv = ["nav", "search", block_map, "--queries", queries, "--param", "weight=2"]
    assert run(*argv, "-o", tmp_path / "one.h5", "-q").exit_code == 1
    assert_forked_from_command(argv, tmp_path / "two.h5", tmp_path / "one.h5", exit_code=1)
