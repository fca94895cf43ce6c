"""TEB band optimization on synthetic straight and L-shaped paths, resizing, yaw wrap-around."""

import numpy as np
import pytest

from legplan.geometry.angles import wrap_angle
from legplan.nav.teb.band import Band
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.initialize import initial_band
from legplan.nav.teb.optimizer import Scene, ViaPoint, limit_violations, objective_terms, optimize_band
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.residuals import PathTerm, band_vector
from legplan.nav.teb.resize import resize
from legplan.nav.teb.yaw import YawPolicy
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import obstacle_distance

PARAMS = TebParams()


def refine(waypoints, table_i, params=PARAMS, **scene):
    path = GlobalPath.from_waypoints(np.array(waypoints, float), speed=0.5)
    band = initial_band(path, params.dt_ref)
    return path, optimize_band(band, table_i, params, Scene(path=path, start_velocity=np.zeros(3), **scene))


def corridor_field(walls_y=(-1.0, 1.0)):
    grid = Grid2D((-2.0, -2.0), 0.05, (81, 281))
    X, Y = grid.centres()
    occupied = (Y <= walls_y[0]) | (Y >= walls_y[1])
    return DistanceField(obstacle_distance(occupied, grid.resolution), grid)


def test_straight_corridor_satisfies_limits_within_epsilon(table_i):
    field = corridor_field()
    path, result = refine([[0, 0], [8, 0]], table_i, distance=field)
    band = result.band
    violations = limit_violations(band, table_i)
    assert max(violations.values()) <= PARAMS.epsilon, violations
    # time-optimal: close to the bang-coast-bang minimum 8/0.75 + 0.75/1.0 ≈ 11.4 s, faster than the 16 s path
    assert band.duration < 12.5
    assert np.abs(band.poses[:, 1]).max() < 0.05 and np.abs(wrap_angle(band.poses[:, 2])).max() < 0.05
    assert np.allclose(band.poses[0], [0, 0, 0]) and np.allclose(band.poses[-1, :2], [8, 0])
    assert field.values(band.poses[:, :2]).min() >= PARAMS.min_obstacle_distance


def test_l_shaped_path_satisfies_limits_within_epsilon(table_i):
    path, result = refine([[0, 0], [5, 0], [5, 4]], table_i)
    band = result.band
    violations = limit_violations(band, table_i)
    assert max(violations.values()) <= PARAMS.epsilon, violations
    assert np.allclose(band.poses[-1, :2], [5, 4])
    assert len(result.rounds) == PARAMS.outer_iterations
    # the band turns the corner: yaw goes from facing +x to facing +y
    assert abs(band.poses[0, 2]) < 1e-9 and abs(wrap_angle(band.poses[-2, 2] - np.pi / 2)) < 0.3


def test_nonomnidirectional_band_has_no_lateral_velocity(table_i):
    path = GlobalPath.from_waypoints(np.array([[0, 0], [4, 0], [4, 3]], float), speed=0.5)
    band = initial_band(path, PARAMS.dt_ref)
    params = PARAMS.replace(omnidirectional=False, outer_iterations=8)  # turning on the spot needs more rounds
    result = optimize_band(band, table_i, params, Scene(path=path, start_velocity=np.zeros(3)))
    poses, dt = result.band.poses, result.band.dt
    mean = poses[:-1, 2] + wrap_angle(np.diff(poses[:, 2])) / 2  # chord direction of an arc
    delta = np.diff(poses[:, :2], axis=0)
    lateral = (-np.sin(mean) * delta[:, 0] + np.cos(mean) * delta[:, 1]) / dt
    assert np.abs(lateral).max() < 0.02
    assert np.abs(poses[-1, :2] - [4, 3]).max() < 1e-9
    assert max(limit_violations(result.band, table_i).values()) <= params.epsilon


def test_via_point_with_heading_is_passed(table_i):
    via = ViaPoint((3.0, 0.3), heading=0.3)
    path, result = refine([[0, 0], [6, 0]], table_i, PARAMS.replace(outer_iterations=8), via=(via,))
    band = result.band
    k = np.argmin(np.hypot(*(band.poses[:, :2] - via.xy).T))
    # pulled 0.3 m off the global path (lateral motion is slow: v_y ≤ 0.2 m/s, a_y ≤ 0.17 m/s²)
    assert np.hypot(*(band.poses[k, :2] - via.xy)) < 0.2 and band.poses[k, 1] > 0.1
    assert abs(wrap_angle(band.poses[k, 2] - 0.3)) < 0.15


def test_resize_splits_and_merges_but_keeps_start_and_goal():
    poses = np.array([[0, 0, 0], [0.1, 0, 0], [0.15, 0, 0], [2.0, 0, 0.5], [2.1, 0.1, 0.5]])
    band = Band(poses, [0.05, 0.05, 1.2, 0.1])
    out = resize(band, PARAMS)
    assert np.allclose(out.poses[0], poses[0]) and np.allclose(out.poses[-1], poses[-1])
    assert out.fixed[0] and out.fixed[-1] and not out.fixed[1:-1].any()
    assert out.duration == pytest.approx(band.duration)
    lower, upper = PARAMS.dt_ref - PARAMS.dt_hysteresis, PARAMS.dt_ref + PARAMS.dt_hysteresis
    assert np.all(out.dt[:-1] <= upper + 1e-12) and np.all(out.dt[:-1] >= lower - 1e-12)


def test_resize_never_goes_below_min_poses():
    band = Band([[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]], [0.01, 0.01])
    out = resize(band, PARAMS)
    assert out.n == PARAMS.min_poses
    assert np.allclose(out.poses[[0, -1]], band.poses[[0, -1]])


def test_yaw_wraps_the_short_way_around_pi(table_i):
    # start facing +179°, goal facing −179°: the band must turn 2°, not 358°
    start, goal = np.pi - np.radians(1), -np.pi + np.radians(1)
    path = GlobalPath.from_waypoints(np.array([[0, 0], [-2.0, 0.0]]), speed=0.5)
    band = initial_band(path, PARAMS.dt_ref, YawPolicy("heading", heading=start), goal_heading=goal)
    result = optimize_band(band, table_i, PARAMS, Scene(path=path, start_velocity=np.zeros(3)))
    turn = np.abs(wrap_angle(np.diff(result.band.poses[:, 2]))).sum()
    assert turn < 0.3  # the long way round would be 2π − 2° ≈ 6.25 rad
    assert np.all(np.abs(result.band.poses[:, 2]) > np.pi / 2)
    # mid-resize yaw interpolation crosses ±π correctly too
    split = resize(Band([[0, 0, start], [0.1, 0, goal]], [1.0]), PARAMS)
    assert np.all(np.abs(split.poses[:, 2]) > np.pi - np.radians(1.01))


def test_yaw_policies():
    pts = np.array([[0, 0], [1, 0], [1, 1]], float)
    vel = np.array([[0, 0], [1, 0], [0, 1]], float)
    assert np.allclose(YawPolicy("velocity").angles(pts, vel), [0, 0, np.pi / 2])
    assert np.allclose(YawPolicy("heading", heading=1.0).angles(pts, vel), 1.0)
    assert np.allclose(YawPolicy("target", target=(1.0, 2.0)).angles(pts, vel)[2], np.pi / 2)


def test_path_attraction_window_follows_arc_length_not_timing(table_i):
    # poses on the path, but the band spends 80 % of its time on the first half (the band is
    # re-timed): each pose must still be attracted to its own point of the path, not pulled along it
    path = GlobalPath.from_waypoints(np.array([[0, 0], [8, 0]], float), speed=0.5)
    s = np.linspace(0, 8, 17)
    band = Band(np.column_stack([s, np.zeros(17), np.zeros(17)]), np.where(s[:-1] < 4, 0.8, 0.2))
    entries = objective_terms(band, table_i, PARAMS, Scene(path=path))
    term = next(e.term for e in entries if isinstance(e.term, PathTerm))
    assert np.abs(term.evaluate([band_vector(band)], False)[0]).max() < 1e-9
