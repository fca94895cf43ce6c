"""The report's sim section: planned against executed, the contact timeline, the fall and the replay."""

import numpy as np
import pytest
from fake_artefacts import write_sim_run, write_traj

from legplan.report import write_report
from legplan.report.execution import _intervals, execution_scene, executed_task
from legplan.terrain.terrain_map import save_map


@pytest.fixture
def plan(tmp_path, flat_terrain):
    flat = tmp_path / "flat.h5"
    save_map(flat_terrain, flat)
    return flat, write_traj(tmp_path / "traj.h5", flat, samples=60, duration=1.2)


def test_executed_task_pairs_the_run_with_its_plan(tmp_path, plan):
    flat, traj = plan
    robot, series, attrs, planned, found = executed_task(write_sim_run(tmp_path / "sim.h5", traj, flat, fall_time=0.6))
    assert found.name == "traj.h5" and planned is not None and attrs["fell"]
    c = series.columns
    # the executed feet (FK of the recorded joints, lowered to the contact point) are the planned ones
    planned_feet = np.stack([np.interp(c["t"], planned["t"], planned["feet_pos"][:, leg, axis])
                             for leg in range(4) for axis in range(3)], axis=1).reshape(-1, 4, 3)
    before = c["t"] <= 0.58  # the fake drops between its 20 ms samples at 0.58 and 0.6 s
    assert np.abs(c["feet_pos"][before] - planned_feet[before]).max() < 3e-3
    assert c["contact"][before].all() and not c["contact"][c["t"] > 0.62].any()


def test_sim_section_has_its_figure_and_a_replay_with_the_fall_marked(tmp_path, plan):
    flat, traj = plan
    sim = write_sim_run(tmp_path / "sim.h5", traj, flat, fall_time=0.6)
    result = write_report([traj, sim], tmp_path / "rep")
    section = result.sections[1]
    assert section.failures == []
    assert [f.filename for f in section.figures] == ["01-sim-execution.png"]
    assert "fell at t = 0.60 s" in section.figures[0].caption and "traj.h5" in section.figures[0].caption
    scene = section.scene
    labels = [frame["label"] for frame in scene["frames"]]
    assert "fell at 0.60 s" in scene["title"]
    assert len(labels) == 121                             # 1.2 s replayed at 100 Hz
    assert not any("fallen" in label for label in labels[:60]) and all("fallen" in label for label in labels[60:])
    drop = np.array(scene["frames"][-1]["c"])[2] - np.array(scene["frames"][0]["c"])[2]
    assert drop == -250                                   # the replay shows the executed base, not the plan
    assert len(scene["frames"][0]["k"]) == 3 * sum(scene["links"]["legs"])
    page = (tmp_path / "rep" / "index.html").read_text()
    assert 'id="01-sim-scene"' in page and "01-sim-execution.png" in page


def test_sim_without_a_fall_says_so(tmp_path, plan):
    flat, traj = plan
    scene = execution_scene(write_sim_run(tmp_path / "sim.h5", traj, flat))
    assert "fell" not in scene["title"] and not any("fallen" in f["label"] for f in scene["frames"])


def test_contact_intervals():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    assert _intervals(t, np.array([1, 1, 0, 1, 1], bool)) == [(0.0, pytest.approx(0.2)), (0.3, pytest.approx(0.1))]
    assert _intervals(t, np.zeros(5, bool)) == []


@pytest.mark.parametrize("damage", ["drop joint_pos", "nan base_pos", "short t", "no joints attr"])
def test_malformed_sim_is_bad_input_and_nothing_is_written(tmp_path, plan, damage):
    """Each class of damage to what the sim section reads: one ArtefactError naming the file and
    the field, before anything is written (the CLI's exit 2)."""
    import h5py

    from legplan.errors import ArtefactError

    flat, traj = plan
    sim = write_sim_run(tmp_path / "sim.h5", traj, flat)
    with h5py.File(sim, "a") as f:
        series = f["tasks/0000/series"]
        if damage == "drop joint_pos":
            del series["joint_pos"]
            field = "joint_pos"
        elif damage == "nan base_pos":
            series["base_pos"][3, 2] = np.nan
            field = "base_pos"
        elif damage == "short t":
            t = series["t"][()]
            del series["t"]
            series["t"] = t[:-2]
            field = "series"
        else:
            del f.attrs["joints"]
            field = "joints"
    with pytest.raises(ArtefactError, match=f"sim.h5.*{field}"):
        write_report([sim], tmp_path / "rep")
    assert not (tmp_path / "rep").exists()
