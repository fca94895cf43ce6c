"""A cached TEB problem refreshed for a new band equals a problem built from scratch for it."""

import numpy as np
import pytest

from legplan.nav.teb.band import Band
from legplan.nav.teb.objective import TebObjective
from legplan.nav.teb.optimizer import Scene, objective_terms
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.problems import ProblemCache, new_problem
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.residuals import band_vector

PARAMS = TebParams()


def band_and_scene(seed):
    rng = np.random.default_rng(seed)
    n = 9
    poses = np.column_stack([np.linspace(0, 2.5, n), 0.1 * rng.standard_normal(n), 0.2 * rng.standard_normal(n)])
    path = GlobalPath.from_waypoints(np.array([[0, 0], [1.0 + rng.uniform(), 0.5], [2.5, 0.0]]), 0.5)
    scene = Scene(path=path, start_velocity=rng.uniform(0, 0.3, 3), goal_velocity=np.zeros(3))
    return Band(poses, rng.uniform(0.2, 0.4, n - 1)), scene


def test_refreshed_problem_matches_a_new_one(table_i):
    cache = ProblemCache()
    first, scene_a = band_and_scene(0)
    second, scene_b = band_and_scene(1)  # same size, other fixed poses, path and start velocity
    problem = cache.problem(first, objective_terms(first, table_i, PARAMS, scene_a), PARAMS.dt_min)
    problem.normal_equations(problem.layout.initial())  # the cached problem has been used once
    entries = objective_terms(second, table_i, PARAMS, scene_b)
    assert cache.problem(second, entries, PARAMS.dt_min) is problem
    fresh = new_problem(second, entries, PARAMS.dt_min)
    theta = fresh.layout.initial()
    assert np.array_equal(problem.layout.initial(), theta)
    ours, reference = problem.normal_equations(theta), fresh.normal_equations(theta)
    assert np.allclose(ours.residual, reference.residual, rtol=1e-12, atol=1e-12)
    assert np.allclose(ours.gradient, reference.gradient, rtol=1e-12, atol=1e-12)
    assert abs(ours.hessian - reference.hessian).max() < 1e-9
    full = problem.layout.values(theta)["band"]
    assert np.array_equal(full, band_vector(second))  # fixed start and goal of the new band


def test_refresh_rejects_another_pattern(table_i):
    band, scene = band_and_scene(0)
    objective = TebObjective(band.n, objective_terms(band, table_i, PARAMS, scene))
    other = Scene(path=scene.path, start_velocity=None, goal_velocity=np.zeros(3))  # no start-velocity rows
    with pytest.raises(ValueError, match="different Jacobian pattern"):
        objective.refresh(objective_terms(band, table_i, PARAMS, other))
