"""A swing foot sphere that must rise over an edge rises ahead of it (`legplan.sim.reference`'s
anticipated lift), so that a plan whose swing point passes close to a pallet's corner executes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from legplan.dyn.terrain import TerrainModel
from legplan.sim.reference import anticipated, foot_centres, swing_progress
from legplan.terrain import Grid2D, terrain_from_heightmap

RADIUS = 0.03
DATA = Path(__file__).parent / "data"
ROOT = Path(__file__).parents[2]


def test_anticipation_rises_at_the_rate_towards_lifted_samples_and_leaves_the_rest():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    z = np.array([0.0, 0.0, 0.3, 0.1, 0.0])
    lifted = np.array([False, False, True, False, False])
    # before the lifted sample: at most 1 m/s below it; after it: the plan's own descent, not delayed
    assert np.allclose(anticipated(t, z, lifted, 1.0), [0.1, 0.2, 0.3, 0.1, 0.0])
    assert np.allclose(anticipated(t, z, np.zeros(5, bool), 1.0), z)   # nothing lifted: nothing changes


def _swing_over_a_step():
    """A 1 cm map with a 14 cm step whose face lies between x = 0 and x = 0.03, and a swing point that
    moves 2 m/s towards it and passes its corner with its point alone clear, 10 ms samples."""
    grid = Grid2D(origin=(-0.5, -0.3), resolution=0.01, shape=(61, 101))
    x, _ = grid.centres()
    terrain = TerrainModel(terrain_from_heightmap(np.clip(x / 0.03, 0.0, 1.0) * 0.14, grid, name="step"))
    t = np.arange(21) * 0.01
    px = -0.2 + 2.0 * t
    pz = 0.16 * np.clip((px + 0.06) / 0.1, 0.0, 1.0) ** 2 * (t < t[-1])   # up late, down at touch-down
    pz[-1] = 0.14
    feet = np.stack([px, np.zeros_like(t), pz], axis=1)[:, None]
    contact = np.zeros((len(t), 1), bool)
    contact[[0, -1]] = True
    normal = terrain.basis(feet[..., 0].ravel(), feet[..., 1].ravel())[0].reshape(len(t), 1, 3)
    return terrain, t, feet, normal, swing_progress(t, contact)


def test_a_swing_sphere_rises_ahead_of_an_edge_at_the_lift_rate():
    terrain, t, feet, normal, progress = _swing_over_a_step()
    at_once = foot_centres(feet, [RADIUS], terrain, normal, progress)[:, 0, 2]
    ahead = foot_centres(feet, [RADIUS], terrain, normal, progress, t, 1.0)[:, 0, 2]
    assert np.max(np.diff(at_once) / np.diff(t)) > 3.0       # sample by sample, the lift jumps at the edge
    assert np.all(ahead >= at_once - 1e-12)                   # never lower
    assert ahead[0] == at_once[0] and ahead[-1] == at_once[-1]  # lift-off and touch-down as before
    lifted = ahead > at_once + 1e-9
    assert lifted.any()
    first = int(np.argmax(lifted))
    edge = int(np.argmax(np.diff(at_once) / np.diff(t))) + 1
    assert first < edge                                       # the foot leaves its path before the edge
    # from where it leaves the path to the edge it rises at the lift rate
    assert np.allclose(np.diff(ahead[first - 1:edge + 1])[1:] / 0.01, 1.0)


@pytest.fixture(scope="module")
def edge_swing_plan():
    """A pallet walk planned with the paper's costs whose check passed (task 91 of
    tasks/single_pallet_walk.yaml, seed 0): its left front swing point passes the pallet's corner a
    few millimetres clear, moving about 3 m/s."""
    stored = np.load(DATA / "pallet_walk_edge_swing.npz")
    samples = {k: np.asarray(stored[k], float if stored[k].dtype.kind == "f" else bool) for k in stored.files}
    goal = tuple(samples.pop("goal"))
    from legplan.terrain.spec import build_map

    return samples, goal, build_map(ROOT / "maps" / "single_pallet.yaml")


def test_the_pallet_walk_whose_swing_passes_the_corner_executes_with_the_anticipated_lift(robot, edge_swing_plan):
    from legplan.sim.run import SimParams, simulate

    samples, goal, pallet = edge_swing_plan
    at_once = simulate(samples, robot, pallet, SimParams(lift_rate=1e3), goal=goal)
    ahead = simulate(samples, robot, pallet, SimParams(), goal=goal)
    assert at_once.fell and "sphere15_shank_lf" in at_once.unplanned_contacts, at_once.reason
    assert ahead.success and not ahead.unplanned_contacts, ahead.reason
