"""`legplan nav simulate` / `nav refine` end to end on the small flat map."""

from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.artefacts import read_provenance
from legplan.cli.main import cli
from legplan.robots import read_navigation

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def flat_map(tmp_path_factory):
    path = tmp_path_factory.mktemp("nav") / "flat.h5"
    result = CliRunner().invoke(cli, ["map", "build", str(ROOT / "maps" / "flat.yaml"), "-o", str(path), "-q"])
    assert result.exit_code == 0, result.output
    return path


def test_simulate_writes_run(flat_map, tmp_path):
    out = tmp_path / "run.h5"
    result = CliRunner().invoke(cli, ["nav", "simulate", str(flat_map), "--start", "-1", "0", "0.3", "--goal",
                                      "0.5", "-0.3", "--outer", "2", "--param", "sim.window=4",
                                      "--param", "search.weight=3", "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out) as f:
        sim = f["simulation"]
        assert sim.attrs["success"] and sim.attrs["collisions"] == 0
        assert sim["state"].shape[1] == 6 and len(sim["command"]) == len(sim["compute_seconds"])
        assert sim["state"][0, 2] == 0.3  # the start yaw
        params = read_provenance(f)["params"]
        assert params["sim"]["window"] == 4.0 and params["search"]["weight"] == 3.0
        assert params["start"] == [-1.0, 0.0, 0.3] and params["goals"][0][:2] == [0.5, -0.3]


@pytest.mark.parametrize("args, message", [
    (["--start", "a", "b", "--goal", "1", "1"], "--start"),
    (["--start", "1", "--goal", "1", "1"], "--start"),
    (["--start", "0", "0", "--goal", "1", "1", "--param", "weight=2"], "search.KEY, teb.KEY or sim.KEY"),
    (["--start", "0", "0", "--goal", "1", "1", "--param", "sim.rate=0"], "field 'rate' must be > 0, got '0'"),
    (["--start", "0", "0", "--goal", "1", "1", "--param", "teb.nope=1"], "teb parameters: field 'nope' is unknown"),
])
def test_simulate_bad_pose_or_param_is_exit_2(flat_map, tmp_path, args, message):
    result = CliRunner().invoke(cli, ["nav", "simulate", str(flat_map), *args, "-o", str(tmp_path / "x.h5")])
    assert result.exit_code == 2 and message in result.stderr, result.stderr
    assert not (tmp_path / "x.h5").exists()


def test_refine_adds_teb_group(flat_map, tmp_path):
    nav = tmp_path / "nav.h5"
    result = CliRunner().invoke(cli, ["nav", "search", str(flat_map), "--start", "-1", "-1", "--goal", "1", "0.8",
                                      "-o", str(nav), "-q"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "teb.h5"
    result = CliRunner().invoke(cli, ["nav", "refine", str(flat_map), str(nav), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(out) as f:
        teb = f["queries/0000/teb"]
        assert teb["poses"].shape[1] == 3 and len(teb["dt"]) == len(teb["poses"]) - 1
        # the optimizer keeps every Table I limit to within its penalty margin ε; the attrs are the band's
        limits, epsilon = read_navigation("jueying_mini").limits, read_provenance(f)["params"]["teb"]["epsilon"]
        violations = [value for key, value in teb.attrs.items() if key.startswith("violation_")]
        assert len(violations) == 7 and teb.attrs["max_violation"] == max(violations) <= epsilon
        v, a = teb["velocity"][()], teb["acceleration"][()]
        assert -limits.v_x_min - epsilon <= v[:, 0].min() and v[:, 0].max() <= limits.v_x_max + epsilon
        assert np.abs(v[:, 1]).max() <= limits.v_y_max + epsilon and np.abs(v[:, 2]).max() <= limits.omega_max + epsilon
        assert (np.abs(a).max(axis=0) <= np.array([limits.a_x_max, limits.a_y_max, limits.alpha_max]) + epsilon).all()
        total = teb.attrs["total_time"]
        assert total == pytest.approx(teb["dt"][()].sum())
        distance = np.linalg.norm(teb["poses"][-1, :2] - teb["poses"][0, :2])
        assert total >= distance / np.hypot(limits.v_x_max, limits.v_y_max)   # no faster than the limits allow
        assert "segments" in f["queries/0000"]  # the search group is kept
    from legplan.nav.artefact import read_queries

    with h5py.File(out) as f:
        band = read_queries(f)[0]["band"]
        assert (band["poses"] == f["queries/0000/teb/poses"][()]).all()
        assert band["total_time"] == f["queries/0000/teb"].attrs["total_time"]
    with h5py.File(nav) as f:
        assert read_queries(f)[0]["band"] is None


def test_report_of_a_refined_artefact_draws_the_band(flat_map, tmp_path):
    import matplotlib.image

    from legplan.report import kinds

    nav, out = tmp_path / "nav.h5", tmp_path / "teb.h5"
    for args in (["nav", "search", str(flat_map), "--start", "-1", "-1", "--goal", "1", "0.8", "-o", str(nav)],
                 ["nav", "refine", str(flat_map), str(nav), "-o", str(out), "--outer", "2"]):
        result = CliRunner().invoke(cli, [*args, "-q"])
        assert result.exit_code == 0, result.output
    searched, refined = tmp_path / "searched.png", tmp_path / "refined.png"
    kinds.nav_paths(nav, searched)
    kinds.nav_paths(out, refined)
    # the band adds its own line over the (dotted) searched path: the images differ in many pixels
    a, b = matplotlib.image.imread(searched), matplotlib.image.imread(refined)
    assert a.shape == b.shape and (abs(a - b).sum(axis=2) > 0.1).sum() > 200
    caption = kinds.nav_profiles(out, tmp_path / "profiles.png")
    assert caption == "Speed profiles of 2 trajectories."
    assert kinds.nav_queries(out, tmp_path / "q.png").startswith("1 query, 1 succeeded")
