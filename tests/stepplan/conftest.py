"""Fixtures of the step-planner tests: the analytic toy robot/terrain and hand-made step pairs."""

import numpy as np
import pytest
from toy import HIPS, ToyHill, ToyRobot, toy_configuration


@pytest.fixture
def toy_robot():
    return ToyRobot()


@pytest.fixture
def flat_feet():
    feet = HIPS.copy()
    feet[:, 2] = 0.0
    return feet


@pytest.fixture
def swing_over_hill(flat_feet):
    """Leg 0 swings 0.2 m forward over a 5 cm hill; the other three stay; the body shifts 2 cm."""
    end = flat_feet.copy()
    end[0, 0] = 0.4
    q0 = toy_configuration([-0.05, -0.03, 0.3], flat_feet)
    q1 = toy_configuration([-0.03, -0.03, 0.3], end)
    return ToyHill(height=0.05, width=0.025), q0, q1, np.array([False, True, True, True]), flat_feet
