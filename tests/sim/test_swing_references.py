"""What makes a plan that passed its check execute: swing feet that clear the edges they pass, and a
controller that keeps a light, heavy-legged robot's trot upright (issue 34, issue 33)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from legplan.artefacts import open_artefact, read_summary
from legplan.cli.main import cli
from legplan.dyn.terrain import TerrainModel
from legplan.sim.reference import foot_centres, swing_progress
from legplan.terrain import Grid2D, terrain_from_heightmap
from legplan.terrain.columns import ColumnDistance
from published_robots import robots_dir

RADIUS = 0.03


def _step_terrain():
    """A 1 cm map with a 14 cm step whose face lies between x = 0 and x = 0.03 (a ramp of cells)."""
    grid = Grid2D(origin=(-0.5, -0.3), resolution=0.01, shape=(61, 101))
    x, _ = grid.centres()
    height = np.clip(x / 0.03, 0.0, 1.0) * 0.14
    return TerrainModel(terrain_from_heightmap(height, grid, name="step")), height, grid


def test_a_swing_foot_sphere_passes_over_an_edge_instead_of_into_its_face():
    terrain, height, grid = _step_terrain()
    # planned points: in stance on the ground, in swing just above the step's face, on the top
    feet = np.array([[[-0.2, 0.0, 0.0]], [[0.015, 0.0, 0.145]], [[0.2, 0.0, 0.14]]])
    normal = terrain.basis(feet[..., 0].ravel(), feet[..., 1].ravel())[0].reshape(3, 1, 3)
    centres = foot_centres(feet, [RADIUS], terrain, normal)
    assert np.allclose(centres[0, 0], [-0.2, 0.0, RADIUS]) and np.allclose(centres[2, 0], [0.2, 0.0, 0.14 + RADIUS])
    swing = centres[1, 0]
    assert np.allclose(swing[:2], feet[1, 0, :2])          # not pushed back along the face's normal
    clearance = ColumnDistance(height, np.asarray(grid.origin, float), grid.resolution, 0.2).values(swing[None])[0]
    assert clearance >= RADIUS - 1e-9                       # the sphere clears every column of the map


def test_a_swing_foot_that_skims_the_terrain_clears_it_by_its_radius_at_mid_swing():
    terrain, height, grid = _step_terrain()
    # a swing point sliding along the step's top (gap 0) from lift-off to touch-down
    t = np.linspace(0.0, 0.4, 5)
    feet = np.stack([np.linspace(0.1, 0.3, 5), np.zeros(5), np.full(5, 0.14)], axis=1)[:, None]
    contact = np.array([1, 0, 0, 0, 1], bool)[:, None]
    normal = terrain.basis(feet[..., 0].ravel(), feet[..., 1].ravel())[0].reshape(5, 1, 3)
    centres = foot_centres(feet, [RADIUS], terrain, normal, swing_progress(t, contact))
    assert np.allclose(centres[[0, 4], 0, 2], 0.14 + RADIUS)          # lift-off and touch-down as planned
    assert centres[2, 0, 2] == pytest.approx(0.14 + 2 * RADIUS)      # mid-swing: one radius clear
    assert np.all(centres[1:4, 0, 2] > 0.14 + RADIUS)


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def test_solo12_drafted_from_its_urdf_executes_its_flat_trot(tmp_path):
    """A 2.5 kg robot with half its mass in the legs: its planned trot (with flight phases) stays
    upright under the controller and reaches the goal."""
    folder = tmp_path / "solo12"
    urdf = robots_dir() / "solo_description/robots/solo12.urdf"
    assert _run("robot", "init", urdf, "-o", folder, "--name", "solo12", "-q").exit_code == 0
    feet = yaml.safe_load((folder / "robot.yaml").read_text())["centroidal"]["nominal_feet"]
    length = max(f[0] for f in feet.values()) - min(f[0] for f in feet.values())
    grid = Grid2D(origin=(-2 * length, -2 * length), resolution=0.01,
                  shape=(int(4 * length / 0.01) + 1, int(5 * length / 0.01) + 1))
    from legplan.terrain import save_map

    save_map(terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat"), tmp_path / "flat.h5")
    traj, sim = tmp_path / "traj.h5", tmp_path / "sim.h5"
    planned = _run("dyn", "plan", tmp_path / "flat.h5", "--robot", folder, "--gait", "trot", "--strides", 4,
                   "--duration", 2.4, "--start", 0, 0, 0, "--goal", length, 0, 0, "-o", traj, "-q")
    assert planned.exit_code == 0, planned.output
    simulated = _run("dyn", "simulate", traj, tmp_path / "flat.h5", "-o", sim, "-q")
    with open_artefact(sim) as handle:
        summary = {key: value for key, (value, _) in read_summary(handle).items()}
    assert simulated.exit_code == 0 and summary["falls"] == 0 and summary["succeeded"] == 1, simulated.output
    assert summary["median_rms_orientation_error"] < 0.1


def test_swing_progress_runs_from_lift_off_to_touch_down():
    t = np.arange(7) * 0.1
    contact = np.array([[1, 1], [0, 1], [0, 1], [0, 1], [1, 1], [1, 0], [1, 1]], bool)
    progress = swing_progress(t, contact)
    assert np.allclose(progress[:, 0], [1, 0.25, 0.5, 0.75, 1, 1, 1])
    assert np.allclose(progress[:, 1], [1, 1, 1, 1, 1, 0.5, 1])


def test_footholds_follow_the_velocity_error_so_a_pushed_trot_keeps_its_feet_under_it(robot):
    """Open loop, a lateral push in a trot can only be caught where the feet land: the same plan and
    push fall with the footholds as planned and reach the goal with the capture-point shift."""
    from pathlib import Path

    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.sim.controller import Gains
    from legplan.sim.run import SimParams, simulate
    from legplan.terrain.spec import build_map

    flat = build_map(Path(__file__).parents[2] / "maps" / "flat.yaml")
    planned = plan(DynTask((0, 0, 0), (1.0, 0, 0), "trot", 4, 2.4), robot.centroidal, TerrainModel(flat), DynParams())
    assert planned.success
    push = ((1.2, 0.0, 110.0, 0.1),)   # 11 N s sideways, mid-plan
    as_planned = simulate(planned.samples, robot, flat, SimParams(pushes=push, gains=Gains(step_feedback=0.0)))
    stepping = simulate(planned.samples, robot, flat, SimParams(pushes=push))
    assert as_planned.fell, as_planned.reason
    assert stepping.success, stepping.reason
