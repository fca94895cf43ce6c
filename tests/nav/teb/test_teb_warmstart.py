"""Warm start of the local band: the shifted band keeps start/goal and needs fewer iterations than a cold start."""

import numpy as np
import pytest

from legplan.nav.teb.band import Band
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.warmstart import shift_band

PARAMS = TebParams()


def straight_band(n=11, length=3.0):
    poses = np.column_stack([np.linspace(0, length, n), np.zeros(n), np.zeros(n)])
    return Band(poses, np.full(n - 1, 0.4))


def test_shift_drops_passed_poses_and_keeps_goal():
    band = straight_band()
    robot = np.array([0.72, 0.02, 0.01])  # 1 s into the 4 s band (0.75 m/s): the band expects x = 0.75
    goal = band.poses[-1].copy()
    shifted = shift_band(band, 1.0, robot, goal, PARAMS.dt_min)
    assert np.allclose(shifted.poses[0], robot) and np.allclose(shifted.poses[-1], goal)
    assert shifted.fixed[0] and shifted.fixed[-1] and not shifted.fixed[1:-1].any()
    assert shifted.n == 9  # poses at 0, 0.3, 0.6 m (t ≤ 0.8 s) were passed
    assert shifted.duration == pytest.approx(band.duration - 1.0, abs=1e-9)
    assert np.all(shifted.poses[1:, 0] > robot[0])


def test_shift_moves_goal_forward_and_stretches_last_interval():
    band = straight_band()
    shifted = shift_band(band, 0.4, [0.3, 0, 0], [3.3, 0.0, 0.0], PARAMS.dt_min)
    assert np.allclose(shifted.poses[-1], [3.3, 0, 0])
    assert shifted.dt[-1] == pytest.approx(0.4 * 0.6 / 0.3)


def test_shift_reports_invalid_band():
    band = straight_band()
    goal = band.poses[-1]
    assert shift_band(band, 1.0, [0.3, 0.8, 0.0], goal, PARAMS.dt_min) is None  # robot far from the band
    assert shift_band(band, 1.0, [0.75, 0.0, 0.0], goal + [1.5, 0, 0], PARAMS.dt_min) is None  # goal jumped
    assert shift_band(band, band.duration + 0.1, goal, goal, PARAMS.dt_min) is None  # band used up


def test_warm_start_needs_fewer_iterations_than_cold_start(table_i):
    path = GlobalPath.from_waypoints(np.array([[0, 0], [3.0, 0.0], [4.5, 1.5]]), speed=0.5)
    scene = Scene(path=path, start_velocity=np.zeros(3))
    previous = optimize_band(initial_band(path, PARAMS.dt_ref), table_i, PARAMS, scene).band
    elapsed = 0.1  # one control cycle: the robot is where the band expected it, with its velocity
    times = previous.times
    robot = np.array([np.interp(elapsed, times, previous.poses[:, i]) for i in range(3)])
    velocity = previous.velocities()[0]
    scene = Scene(path=path, start_velocity=velocity)
    warm = optimize_band(shift_band(previous, elapsed, robot, previous.poses[-1], PARAMS.dt_min), table_i, PARAMS, scene)
    cold = optimize_band(initial_band(path, PARAMS.dt_ref, start_pose=robot), table_i, PARAMS, scene)
    assert warm.iterations < cold.iterations
    assert len(warm.rounds) < len(cold.rounds)
    assert np.allclose(warm.band.poses[-1], previous.poses[-1]) and np.allclose(warm.band.poses[0], robot)
