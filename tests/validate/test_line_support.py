"""The check's `line_support`: the longest phase on the same one or two feet, in units of √(h/g),
judged by `CheckTolerances.line_support` (a slow trot passed its check and fell)."""

import numpy as np
import pytest

from legplan.robots import load_robot
from legplan.validate import check_trajectory
from legplan.validate.trajectory import GRAVITY, CheckTolerances, _line_support


@pytest.fixture(scope="module")
def anymal():
    return load_robot("anymal")


def test_the_longest_run_on_the_same_one_or_two_feet_is_measured():
    t = np.arange(10) * 0.1
    four, diagonal, other, one, none = [1, 1, 1, 1], [1, 0, 0, 1], [0, 1, 1, 0], [1, 0, 0, 0], [0, 0, 0, 0]
    contact = np.array([four, diagonal, diagonal, diagonal, other, other, none, one, one, four], bool)
    assert _line_support(t, contact) == pytest.approx(0.3)       # three samples on one diagonal
    contact[4:6] = diagonal                                       # the same pair on: one run of five
    assert _line_support(t, contact) == pytest.approx(0.5)
    assert _line_support(t, np.ones((10, 4), bool)) == 0.0       # a support polygon throughout
    assert _line_support(t, np.array([none] * 10, bool)) == 0.0  # a flight is no support line


def _diagonal_stance(model, duration, n=41, height=0.42):
    """Standing on the lf–rh diagonal for `duration` s, the base over the line, each foot carrying m g / 2."""
    t = np.linspace(0.0, duration, n)
    zeros = np.zeros((n, 3))
    feet = np.tile(model.nominal_feet + [0.0, 0.0, height], (n, 1, 1))
    feet[:, [1, 2], 2] = 0.1                                      # rf and lh 10 cm up, in swing
    centre = feet[0, [0, 3]].mean(axis=0)
    forces = np.zeros((n, 4, 3))
    forces[:, [0, 3], 2] = model.mass * GRAVITY / 2
    contact = np.zeros((n, 4), bool)
    contact[:, [0, 3]] = True
    return {"t": t, "base_pos": np.tile([centre[0], centre[1], height], (n, 1)), "base_vel": zeros.copy(),
            "base_acc": zeros.copy(), "base_euler": zeros.copy(), "base_euler_rate": zeros.copy(),
            "base_ang_vel": zeros.copy(), "base_ang_acc": zeros.copy(), "feet_pos": feet,
            "feet_vel": np.zeros((n, 4, 3)), "forces": forces, "contact": contact}


def test_a_long_stance_on_a_diagonal_fails_the_check_and_a_short_one_passes(anymal, flat_terrain):
    model = anymal.centroidal
    tau = np.sqrt(model.base_height / GRAVITY)
    bound = CheckTolerances().line_support
    short = check_trajectory(_diagonal_stance(model, 0.5 * bound * tau), model, flat_terrain, anymal)
    long = check_trajectory(_diagonal_stance(model, 1.5 * bound * tau), model, flat_terrain, anymal)
    spacing = 1.5 * bound * tau / 40
    assert long.worst["line_support"] == pytest.approx(1.5 * bound + spacing / tau)
    assert short.passed["line_support"] and not long.passed["line_support"]
    assert "line_support" in " ".join(long.failures()) and long.tolerance["line_support"] == bound
    assert long.as_dict()["line_support_tolerance"] == bound
